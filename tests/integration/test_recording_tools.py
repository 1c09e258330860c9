"""rtcf diff and rtcf plot on real recordings of rtcf launch --sim --record: the
expected first difference is computed independently, by reading both files with
rosbags; the plot's axes are checked on the matplotlib Figure it draws."""

import re
import sys
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from rtcf._cli._recording_tools import plot_recording
from rtcf._core._errors import ConfigurationError

from .._launches import EVERY_KIND
from .conftest import SRC, run_rtcf

pytestmark = pytest.mark.integration

LAUNCH = SRC / "rtcf_examples" / "launch"
CASCADE = LAUNCH / "cascade.launch"
SINE = LAUNCH / "sine_cascade.launch"
FIRST = re.compile(
    r"^first difference: (?P<topic>\S+) at iteration (?P<iteration>\d+) "
    r"\(t = (?P<t>\S+) s\): (?P<a>.+) in a\.mcap, (?P<b>.+) in b\.mcap$",
    re.M,
)


def record(path, launch, *args, duration="0.2"):
    result = run_rtcf("launch", launch, *args, "--sim", "--duration", duration, "--record", path)
    assert result.returncode == 0, result.stderr
    return path


def diffed(tmp_path, launch, *changed):
    """``launch`` recorded as it is (a.mcap) and with the launch arguments ``changed``
    (b.mcap): their paths and ``rtcf diff a.mcap b.mcap``."""
    a = record(tmp_path / "a.mcap", launch)
    b = record(tmp_path / "b.mcap", launch, *changed)
    return a, b, run_rtcf("diff", a, b)


def by_iteration(path, period_ns):
    """topic -> {iteration: value}, read with rosbags (under --sim: stamp = i x period)."""
    out = {}
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as r:
        for con, stamp, raw in r.messages():
            if con.topic.endswith("/iteration_info"):
                continue  # the loop's timing rows: rtcf diff leaves them out by default
            assert stamp % period_ns == 0
            msg = r.deserialize(raw, con.msgtype)
            out.setdefault(con.topic, {})[stamp // period_ns] = msg.data
    return out


def expected_first(a, b):
    """(iteration, topic, value in a or None, value in b or None) of the first
    difference, topics in name order within an iteration."""
    found = []
    for topic in sorted(set(a) & set(b)):
        for i in sorted(set(a[topic]) | set(b[topic])):
            va, vb = a[topic].get(i), b[topic].get(i)
            if va != vb:
                found.append((i, topic, va, vb))
                break
    return min(found)


def test_two_recordings_of_the_same_launch_file_are_identical(tmp_path):
    a, b, result = diffed(tmp_path, CASCADE)
    assert result.returncode == 0, result.stderr
    assert result.stdout == "identical: 6 topics, 1320 messages\n"
    only = run_rtcf("diff", a, b, "--topics", "/cascade/velocity.*")
    assert (only.returncode, only.stdout) == (0, "identical: 2 topics, 500 messages\n")


def test_a_changed_gain_shows_its_first_difference_with_both_values(tmp_path):
    a, b, result = diffed(tmp_path, SINE, "gain:=0.6")
    assert result.returncode == 1, result.stderr
    assert result.stdout.startswith(f"{a} and {b} differ\n")
    period = 1_000_000  # 1 kHz
    iteration, topic, va, vb = expected_first(by_iteration(a, period), by_iteration(b, period))
    assert iteration > 0  # the plant's first output is 0 whatever the gain
    m = FIRST.search(result.stdout)
    assert m, result.stdout
    assert (m["topic"], int(m["iteration"])) == (topic, iteration)
    assert float(m["t"]) == pytest.approx(iteration * 1e-3)
    assert float(m["a"]) == pytest.approx(va, rel=1e-5)
    assert float(m["b"]) == pytest.approx(vb, rel=1e-5)
    assert va != pytest.approx(vb, rel=1e-3)  # values that differ in what is shown
    # the other topics that differ are listed with their first iteration
    assert re.search(rf"^  {re.escape(topic)} +{iteration}$", result.stdout, re.M)
    assert "only in" not in result.stdout and "message counts differ" not in result.stdout
    # the setpoint does not depend on the gain: left out, the rest still differs
    same = run_rtcf("diff", a, b, "--topics", "/demo/setpoint")
    assert (same.returncode, same.stdout) == (0, "identical: 1 topics, 200 messages\n")


def test_a_slower_controller_shows_missing_messages_and_counts(tmp_path):
    a, b, result = diffed(tmp_path, CASCADE, "position_rate:=250")
    assert result.returncode == 1, result.stderr
    period = 500_000  # 2 kHz
    ra, rb = by_iteration(a, period), by_iteration(b, period)
    iteration, topic, va, vb = expected_first(ra, rb)
    m = FIRST.search(result.stdout)
    assert m, result.stdout
    assert (m["topic"], int(m["iteration"])) == (topic, iteration)
    assert (va is None) == (m["a"] == "no message") and (vb is None) == (m["b"] == "no message")
    shown = [float(v) for v in (m["a"], m["b"]) if v != "no message"]
    assert shown == pytest.approx([v for v in (va, vb) if v is not None])
    counts = {t: (len(ra[t]), len(rb[t])) for t in ra if len(ra[t]) != len(rb[t])}
    assert counts == {"/cascade/velocity_setpoint": (100, 50)}
    assert re.search(
        r"^message counts differ:\n  /cascade/velocity_setpoint +100 in a\.mcap, "
        r"50 in b\.mcap$",
        result.stdout,
        re.M,
    )


def test_recordings_of_other_topics_and_bad_input(tmp_path):
    a = record(tmp_path / "a.mcap", CASCADE, duration="0.01")
    b = record(tmp_path / "b.mcap", SINE, duration="0.01")
    result = run_rtcf("diff", a, b)
    assert result.returncode == 1
    assert "only in a.mcap: /cascade/position, " in result.stdout
    assert "only in b.mcap: /demo/controller/unused, " in result.stdout
    not_mcap = tmp_path / "notes.mcap"
    not_mcap.write_text("hello")
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(a.read_bytes()[:600])
    for args, named in (
        ((a, tmp_path / "missing.mcap"), "missing.mcap: cannot read it: No such file"),
        ((not_mcap, a), "notes.mcap: not an MCAP file"),
        ((a, truncated), "truncated.mcap: not a readable MCAP file"),
        ((a, a, "--topics", "("), "--topics '(' is not a valid regular expression"),
    ):
        result = run_rtcf("diff", *args)
        assert result.returncode == 2, (args, result.stderr)
        assert result.stdout == ""
        assert result.stderr.count("\n") == 1 and named in result.stderr, result.stderr
        assert result.stderr.startswith("rtcf: error: ")


def test_plot_draws_the_cascade_on_a_shared_time_axis(tmp_path):
    rec = record(tmp_path / "run.mcap", CASCADE)
    topics = [
        "/cascade/position_setpoint",
        "/cascade/position",
        "/cascade/velocity",
        "/cascade/torque",
    ]
    out = tmp_path / "cascade.png"
    result = run_rtcf("plot", rec, *topics, "-o", out)
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000
    fig = plot_recording(str(rec), topics)
    axes = fig.axes
    assert [ax.get_title(loc="left") for ax in axes] == topics
    assert all(ax.get_shared_x_axes().joined(axes[0], ax) for ax in axes)
    assert axes[-1].get_xlabel().startswith("time [s]")
    assert axes[0].get_xlim() == pytest.approx((0.0, 0.2))  # 400 iterations of 0.5 ms
    for ax in axes:
        (line,) = [ln for ln in ax.get_lines() if ln.get_drawstyle() == "steps-post"]
        x = line.get_xdata()
        assert x[0] == 0.0 and x[-1] == pytest.approx(0.2)  # held to the end of the run
    setpoint = next(ln for ln in axes[0].get_lines() if ln.get_drawstyle() == "steps-post")
    assert len(setpoint.get_xdata()) == 10 + 1  # 50 Hz for 0.2 s, and the hold to the end
    # the default PNG is beside the file; a regex full-matches topics; --overlay: one axes
    result = run_rtcf("plot", rec, "/cascade/velocity.*", "--overlay")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "run.png").stat().st_size > 0
    fig = plot_recording(str(rec), ["/cascade/velocity.*"], overlay=True)
    (ax,) = fig.axes
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["/cascade/velocity", "/cascade/velocity_setpoint"]


def test_plot_draws_an_array_as_one_line_per_element(tmp_path):
    launch = tmp_path / "kinds.launch"
    launch.write_text(EVERY_KIND)
    rec = record(tmp_path / "kinds.mcap", launch, duration="0.1")
    fig = plot_recording(str(rec), ["/a", "/b", "/f"])
    steps = [[ln for ln in ax.get_lines() if ln.get_drawstyle() == "steps-post"] for ax in fig.axes]
    assert [len(s) for s in steps] == [3, 1, 1]
    assert [ln.get_label() for ln in steps[0]] == ["data[0]", "data[1]", "data[2]"]
    assert list(steps[0][1].get_ydata()) == [0.5, 3.5, 6.5, 9.5, 9.5]  # iterations 0, 3, 6, 9
    assert list(steps[1][0].get_ydata()[:3]) == [0.0, 1.0, 0.0]  # false, true, false
    result = run_rtcf("plot", rec, "/s")
    assert result.returncode == 1
    assert "/s (std_msgs/msg/String): data holds no numbers to plot" in result.stderr


def test_plot_marks_where_a_slower_topic_was_written_in_every_subplot(tmp_path):
    # the cascade's position setpoint comes at 50 Hz: ten marks in 0.2 s, at its times
    rec = record(tmp_path / "run.mcap", CASCADE)
    topics = ["/cascade/position", "/cascade/torque"]
    fig = plot_recording(str(rec), topics, marks="/cascade/position_setpoint")
    for ax in fig.axes:
        (marks,) = ax.collections
        xs = sorted(seg[0][0] for seg in marks.get_segments())
        assert xs == pytest.approx([k * 0.02 for k in range(10)])
        assert "/cascade/position_setpoint written (10)" in [
            t.get_text() for t in ax.get_legend().get_texts()]
    out = tmp_path / "marked.png"
    result = run_rtcf("plot", rec, *topics, "--marks", "/cascade/position_setpoint", "-o", out)
    assert result.returncode == 0 and out.stat().st_size > 10_000, result.stderr
    result = run_rtcf("plot", rec, *topics, "--marks", "/nothing")
    assert result.returncode == 1 and "has no topic '/nothing'" in result.stderr


def test_plot_of_an_unknown_topic_lists_the_topics(tmp_path, monkeypatch):
    rec = record(tmp_path / "run.mcap", CASCADE, duration="0.01")
    result = run_rtcf("plot", rec, "/cascade/position", "/cascade/nope")
    assert result.returncode == 1
    assert result.stderr == (
        f"rtcf: error: {rec} has no topic '/cascade/nope'; its topics: /cascade/position, "
        "/cascade/position_setpoint, /cascade/torque, /cascade/tracking_error, "
        "/cascade/velocity, /cascade/velocity_setpoint, /rt_runner/iteration_info\n"
    )
    assert not (tmp_path / "run.png").exists()
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if it were not installed
    with pytest.raises(ConfigurationError, match=r"pip install 'rtcf\[plot\]'"):
        plot_recording(str(rec), ["/cascade/position"])


def test_a_real_time_recording_and_its_replay_are_identical(tmp_path):
    # the recording is stamped with wall time, the replay from 0: log times are
    # compared from each file's first message
    rec = tmp_path / "rt.mcap"
    result = run_rtcf("launch", CASCADE, "--duration", "0.2", "--record", rec, "--quiet")
    assert result.returncode == 0, result.stderr
    assert run_rtcf("replay", rec).returncode == 0
    result = run_rtcf("diff", rec, tmp_path / "rt.replay.mcap")
    assert (result.returncode, result.stdout) == (0, "identical: 6 topics, 1320 messages\n")
