"""Two runners on two "hosts": network namespaces joined by a veth pair, as two
computers on one Ethernet link, talking ROS 2 over DDS (docs/ros2.md#several-machines).

The hosts are benchmarks/_hosts.py's: each namespace has its loopback and its end of
the link, a multicast route for DDS discovery, and nothing else (no traffic leaves
them). Fast DDS is told to use UDP only (``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``): between
two real hosts there is no shared memory, and on this one it would otherwise carry the
data past the link.

Host A counts (a Ramp publishes 1, 2, 3 ... on ``/hosts/seq``); host B echoes what
it reads (an Identity to ``/hosts/back``); A reads the echo back. The checks use the
sequence numbers, not a timing bound: every number B read is one A sent, in order;
every number from B's first read on was read or counted as replaced by a newer one;
nothing arrived that is not counted; the traffic crossed the link.
"""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import rtcf_env

pytestmark = pytest.mark.integration

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import _hosts  # noqa: E402  (benchmarks/_hosts.py: ros2_latency.py --hosts 2 uses it too)

sys.path.pop(0)


@pytest.fixture
def hosts():
    """Two network namespaces joined by a veth pair; removed afterwards."""
    if os.geteuid() != 0:
        pytest.fail(f"test_several_hosts: {_hosts.NEEDS}: run the ROS 2 suite as root, "
                    "as CI does")
    with _hosts.two_hosts() as pair:
        yield pair


def _launch(tmp_path: Path, name: str, frequency: float, nodes: str) -> Path:
    path = tmp_path / f"{name}.launch"
    path.write_text(f"""<launch>
  <node name="rt_runner_{name}" pkg="rtcf" type="rt_runner">
    <rosparam param="mode">"no_wait"</rosparam>
    <rosparam param="frequency">{frequency}</rosparam>
    <rosparam param="ros_mapping_whitelist">"/hosts/.*"</rosparam>
    <rosparam param="iteration_info">False</rosparam>
  </node>
{nodes}
</launch>
""")
    return path


def _start(host, launch: Path, duration: float, out: Path) -> subprocess.Popen:
    env = {**rtcf_env(), **_hosts.UDP_ONLY}
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    cmd = host.command(sys.executable, "-m", "rtcf", "launch", str(launch), "--middleware",
                       "ros2", "--duration", str(duration), "--record", str(out / "run.mcap"),
                       "--report", str(out))
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True, env=env)


def _values(path: Path, topic: str) -> list[float]:
    """The recorded std_msgs/msg/Float64 values of a topic (CDR: a 4-byte header, the
    double)."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return [struct.unpack_from("<d", m.data, 4)[0]
                for _, _, m in make_reader(f).iter_messages(topics=[topic])]


def test_two_runners_on_two_hosts_exchange_topics_and_count_every_message(hosts, tmp_path):
    host_a, host_b = hosts
    a = _launch(tmp_path, "a", 50.0, """
  <node name="count" pkg="rtcf" type="rt_launcher" args="rtcf_examples Ramp">
    <remap from="out" to="/hosts/seq"/>
  </node>
  <node name="heard" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
    <remap from="in_port" to="/hosts/back"/><remap from="out_port" to="/heard"/>
  </node>""")
    b = _launch(tmp_path, "b", 200.0, """
  <node name="echo" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
    <remap from="in_port" to="/hosts/seq"/><remap from="out_port" to="/hosts/back"/>
  </node>""")
    out_a, out_b = tmp_path / "a", tmp_path / "b"
    out_a.mkdir()
    out_b.mkdir()
    rx_before = host_b.received_bytes()
    # B listens from before A starts until after A ends; A counts for 6 s at 50 Hz
    proc_b = _start(host_b, b, 12.0, out_b)
    proc_a = _start(host_a, a, 8.0, out_a)
    try:
        _, err_a = proc_a.communicate(timeout=120)
        _, err_b = proc_b.communicate(timeout=120)
    finally:
        for p in (proc_a, proc_b):
            p.kill()
    assert proc_a.returncode == 0, err_a
    assert proc_b.returncode == 0, err_b
    sent = _values(out_a / "run.mcap", "/hosts/seq")
    read_b = _values(out_b / "run.mcap", "/hosts/back")
    heard_a = _values(out_a / "run.mcap", "/heard")
    n = len(sent)
    assert sent == [float(k) for k in range(1, n + 1)] and n > 300
    # B's loop follows A's values: each one A sent, in order, up to A's last
    assert read_b, f"host B read nothing of A's {n} numbers:\n{err_b}"
    assert read_b == sorted(set(read_b)) and set(read_b) <= set(sent)
    assert read_b[-1] == n  # B outlived A: it read the last number
    inputs_b = json.loads((out_b / "timing.json").read_text())["inputs"]["/hosts/seq"]
    # every message that arrived was read or replaced by a newer one: none uncounted
    assert inputs_b["arrived"] == inputs_b["read"] + inputs_b["superseded"]
    assert inputs_b["read"] == len(read_b)
    # from B's first read on, every number A sent arrived (read, or counted replaced):
    # DDS lost nothing on the link
    missing = set(range(int(read_b[0]), n + 1)) - set(read_b)
    assert len(missing) <= inputs_b["superseded"]
    assert inputs_b["arrived"] >= n - read_b[0] + 1
    # and back: A heard B's echo of its own numbers, in order
    assert heard_a and heard_a == sorted(set(heard_a)) and set(heard_a) <= set(read_b)
    inputs_a = json.loads((out_a / "timing.json").read_text())["inputs"]["/hosts/back"]
    assert inputs_a["arrived"] >= inputs_a["read"] + inputs_a["superseded"]
    assert inputs_a["read"] == len(heard_a)
    # the messages went over the link (UDP), not through this machine's shared memory
    assert host_b.received_bytes() - rx_before > 20 * n
