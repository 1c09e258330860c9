"""rtcf launch --record: every value of every port at loop rate, in a standard MCAP
file, read back with an independent reader (rosbags) and checked value by value."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from .._launches import EVERY_KIND, launch_xml, runner_xml
from .._proc import env_with
from .conftest import FIXTURES, SRC, run_rtcf
from .test_cascade_example import N, _reference

pytestmark = pytest.mark.integration

CASCADE = SRC / "rtcf_examples" / "launch" / "cascade.launch"


def read(path):
    """topic -> [(iteration, log_time_ns, message)] with rosbags, and the msg types."""
    out, types = {}, {}
    store = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([Path(path)], default_typestore=store) as reader:
        for con in reader.connections:
            types[con.topic] = con.msgtype
        for con, stamp, raw in reader.messages():
            msg = reader.deserialize(raw, con.msgtype)
            out.setdefault(con.topic, []).append((stamp, msg))
    return out, types


def mcap_extras(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        attachments = {a.name: bytes(a.data) for a in reader.iter_attachments()}
        sequences = {}
        for _, channel, message in reader.iter_messages():
            sequences.setdefault(channel.topic, []).append(message.sequence)
    return meta, attachments, sequences


def test_the_cascade_recorded_under_sim_holds_every_value_of_every_port(tmp_path):
    path = tmp_path / "run.mcap"
    result = run_rtcf("launch", CASCADE, "--sim", "--duration", "0.2", "--record", path)
    assert result.returncode == 0, result.stderr
    # 1320 values of 6 port topics, and the 400 iterations' timing rows
    assert f"recorded 1720 messages on 7 topics into {path}; dropped: 0" in result.stderr
    messages, types = read(path)
    assert types.pop("/rt_runner/iteration_info") == "std_msgs/msg/Float64MultiArray"
    assert set(types.values()) == {"std_msgs/msg/Float64"}
    info = [list(m.data) for _, m in messages["/rt_runner/iteration_info"]]
    assert [row[0] for row in info] == list(range(N))
    assert [row[1] for row in info] == [i * 500_000 * 1e-9 for i in range(N)]  # stamps [s]
    meta, attachments, sequences = mcap_extras(path)
    expected = _reference(N)
    # each topic's messages are its writes: the iterations of its component, in order
    ran = {"position": range(N), "velocity": range(N), "torque": range(N),
           "velocity_setpoint": range(1, N, 4), "position_setpoint": range(0, N, 40),
           "tracking_error": range(0, N, 40)}
    for key, iterations in ran.items():
        topic = f"/cascade/{key}"
        assert sequences[topic] == list(iterations), topic
        stamps = [stamp for stamp, _ in messages[topic]]
        assert stamps == [i * 500_000 for i in iterations], topic  # 0.5 ms per iteration
        values = [m.data for _, m in messages[topic]]
        assert values == [expected[key][i] for i in iterations], topic
    rtcf_meta = meta["rtcf"]
    assert json.loads(rtcf_meta["dropped"]) == {} and rtcf_meta["simulated"] == "true"
    assert json.loads(rtcf_meta["order"])[0] == "/cascade/motor"
    assert json.loads(rtcf_meta["iterations"]) == N
    assert attachments["launch/cascade.launch"] == CASCADE.read_bytes()
    assert json.loads(attachments["settings.json"])["frequency"] == 2000.0
    assert json.loads(attachments["timing.json"])["iterations"] == N
    assert rtcf_meta["timing_topic"] == "/rt_runner/iteration_info"
    # rtcf evaluate (the original's evaluate_performance_rosbag) reads the timing rows
    result = run_rtcf("evaluate", path, "2000", "--json", "--output", tmp_path / "fig2.png")
    assert result.returncode == 0, result.stderr
    fig2 = json.loads(result.stdout)
    assert fig2["topic"] == "/rt_runner/iteration_info" and fig2["samples"] == N
    assert (tmp_path / "fig2.png").stat().st_size > 0


def test_every_kind_of_value_and_a_topic_filter(tmp_path):
    launch = tmp_path / "kinds.launch"
    launch.write_text(EVERY_KIND)
    path = tmp_path / "kinds.mcap"
    result = run_rtcf("launch", launch, "--sim", "--duration", "0.1", "--record", path,
                      "--record-topics", "/[fibsa]")
    assert result.returncode == 0, result.stderr
    messages, types = read(path)
    assert types.pop("/rt_runner/iteration_info") == "std_msgs/msg/Float64MultiArray"
    assert types == {
        "/f": "std_msgs/msg/Float64", "/i": "std_msgs/msg/Int64", "/b": "std_msgs/msg/Bool",
        "/s": "std_msgs/msg/String", "/a": "std_msgs/msg/Float64MultiArray",
    }
    assert [m.data for _, m in messages["/f"]] == [k * 0.25 for k in range(10)]
    assert [m.data for _, m in messages["/i"]] == [-k for k in range(10)]
    assert [m.data for _, m in messages["/b"]] == [k % 2 == 1 for k in range(10)]
    assert [m.data for _, m in messages["/s"]] == [f"iteration {k}" for k in range(10)]
    arrays = [list(m.data) for _, m in messages["/a"]]
    assert arrays == [[k, k + 0.5, -1e300] for k in (0, 3, 6, 9)]
    assert [m.layout.dim[0].size for _, m in messages["/a"]] == [3, 3, 3, 3]
    only = tmp_path / "only.mcap"
    result = run_rtcf("launch", launch, "--sim", "--duration", "0.1", "--record", only,
                      "--record-topics", "/f|/s")
    assert result.returncode == 0, result.stderr
    assert set(read(only)[1]) == {"/f", "/s", "/rt_runner/iteration_info"}


def test_a_real_time_recording_counts_what_it_could_not_keep(tmp_path):
    path = tmp_path / "rt.mcap"
    result = run_rtcf("launch", CASCADE, "--duration", "0.5", "--record", path, "--quiet")
    assert result.returncode == 0, result.stderr
    meta, _, sequences = mcap_extras(path)
    dropped = json.loads(meta["rtcf"]["dropped"])
    # every write of the motor (1000 iterations) is in the file or counted as dropped
    kept = len(sequences.get("/cascade/position", []))
    assert kept + dropped.get("/cascade/position", 0) == 1000
    assert json.loads(meta["rtcf"]["messages"])["/cascade/position"] == kept
    # the timing rows and the values carry one ROS time per iteration, to the
    # nanosecond: the loop stamps with the offset the supervisor stamps the rows with
    stamps = {}
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            stamps.setdefault(channel.topic, {})[message.sequence] = message.log_time
    rows, values = stamps["/rt_runner/iteration_info"], stamps["/cascade/position"]
    both = sorted(set(rows) & set(values))
    assert len(both) > 900
    assert [values[i] - rows[i] for i in both] == [0] * len(both)


def test_bad_recording_options_are_one_clear_line(tmp_path):
    result = run_rtcf("launch", CASCADE, "--sim", "--duration", "0.01", "--record",
                      tmp_path / "x.mcap", "--record-topics", "(")
    assert result.returncode == 1
    assert "rtcf: error: --record-topics '(' is not a valid regular expression" in result.stderr
    result = run_rtcf("launch", CASCADE, "--sim", "--duration", "0.01", "--record",
                      tmp_path / "no" / "dir" / "x.mcap")
    assert result.returncode == 1
    assert "cannot write it: No such file or directory" in result.stderr


def test_a_stalled_supervisor_loses_nothing_of_a_float_array_at_1khz(tmp_path):
    """The supervisor stopped (SIGSTOP) for 500 ms while the loop writes three floats
    each millisecond: its ring holds them (a byte ring: 48 bytes a record, where a ring
    of 64 KiB records held 64 of them), and every value is in the file after."""
    launch = tmp_path / "triple.launch"
    launch.write_text(launch_xml(
        '<node name="t" pkg="rtcf" type="rt_launcher" args="rtcf_test_components Triple"/>',
        runner_xml(1000.0),
    ))
    path = tmp_path / "triple.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "rtcf", "launch", str(launch), "--duration", "2", "--record",
         str(path), "--quiet"],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=env_with(FIXTURES),
    )
    try:
        assert proc.stderr is not None
        seen = []
        for line in proc.stderr:  # until the loop runs
            seen.append(line)
            if line.startswith("rtcf: running"):
                break
        else:
            pytest.fail("".join(seen))
        time.sleep(0.3)
        proc.send_signal(signal.SIGSTOP)  # the supervisor: the worker runs on
        time.sleep(0.5)
        proc.send_signal(signal.SIGCONT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGCONT)
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, "".join(seen) + err
    assert f"recorded 4000 messages on 2 topics into {path}; dropped: 0" in err, err
    meta, _, sequences = mcap_extras(path)
    assert json.loads(meta["rtcf"]["dropped"]) == {}
    assert sequences["/a"] == list(range(2000))
    messages, _ = read(path)
    assert [list(m.data) for _, m in messages["/a"]] == [[k, k + 0.5, -k] for k in range(2000)]
