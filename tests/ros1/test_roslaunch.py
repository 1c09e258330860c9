"""Plain roslaunch starts rtcf's ROS 1 rt_runner and rt_launcher (pkg="rtcf").

ROS_PACKAGE_PATH holds ros1/ (the packages rtcf and rtcf_msgs) and src/ (rtcf_examples
and its launch files), as docs/ros1.md's one-time setup says.
"""

import pytest
import rosgraph
from std_msgs.msg import Float64

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, roslaunch, rtcf_launch

pytestmark = pytest.mark.integration


def _round_trip(topics, topic_in, topic_out, value, expected, timeout=10.0):
    got = topics.sub(topic_out, Float64)
    pub = topics.pub(topic_in, Float64)
    ok = wait_until(
        lambda: any(abs(m.data - expected) < 1e-9 for m in got),
        timeout,
        publish=lambda: pub.publish(Float64(value)),
    )
    return ok, [m.data for m in got[-5:]]


def test_listing2_runs_unchanged_under_roslaunch(topics):
    launch = roslaunch("rtcf_examples", "paper_example.launch")
    try:
        err = wait_for(launch, "/rt_runner: running", timeout=30)
        assert "loaded /example1 (rtcf_examples.PaperExample)" in err
        assert "loaded /example2 (rtcf_examples.PaperExample)" in err
        ok, seen = _round_trip(topics, "/ros/in", "/ros/out", 4.25, 4.25)
        assert ok, seen
    finally:
        (err,) = end(launch)
    assert "/rt_runner: stopped after" in err, err


def test_sum_test_of_the_original(topics):
    launch = roslaunch("rtcf_examples", "sum_test.launch")
    try:
        wait_for(launch, "/rtcf/rt_runner: running", timeout=30)
        # "running" comes just before the run opens its topics
        assert wait_until(lambda: {"/rtcf/ros/in", "/rtcf/ros/out"} <= _topics()), _topics()
        names = _topics()
        assert "/rtcf/ros/blacklisted" not in names
        got = topics.sub("/rtcf/ros/out", Float64)
        pub = topics.pub("/rtcf/ros/in", Float64)
        for value in (-10.0, 0.0, 20.0, 1234.56):
            assert wait_until(
                lambda v=value: bool(got) and abs(got[-1].data - 3 * v) < 1e-9,
                10.0,
                publish=lambda v=value: pub.publish(Float64(v)),
            ), (value, [m.data for m in got[-5:]])
    finally:
        (err,) = end(launch)
    assert "stopped after" in err, err


@pytest.mark.parametrize("file", ["paper_example.launch", "sum_test.launch"])
def test_rtcf_launch_middleware_ros1_gives_the_same_result(topics, file):
    """Without roslaunch: the same round trips through the same topics."""
    launch = rtcf_launch("rtcf_examples", file)
    prefix = "/rtcf" if file == "sum_test.launch" else ""
    factor = 3.0 if file == "sum_test.launch" else 1.0
    try:
        said = wait_for(launch, "running until Ctrl-C", timeout=30)
        assert (
            f"rtcf: ros1: publishes {prefix}/ros/out (float); "
            f"subscribes {prefix}/ros/in (float)"
        ) in said
        assert wait_until(
            lambda: {f"{prefix}/ros/in", f"{prefix}/ros/out"} <= _topics()
        ), _topics()
        assert f"{prefix}/ros/blacklisted" not in _topics()
        for value in (-10.0, 1234.56):
            ok, seen = _round_trip(
                topics, f"{prefix}/ros/in", f"{prefix}/ros/out", value, factor * value
            )
            assert ok, (value, seen)
    finally:
        (err,) = end(launch)
    assert "Traceback" not in err, err


def _topics():
    pubs, subs, _ = rosgraph.Master("/rtcf_test").getSystemState()
    return {t for t, _ in pubs} | {t for t, _ in subs}


@pytest.mark.parametrize(
    "file, components",
    [
        ("paper_evaluation.launch", 5),
        ("complex_architecture.launch", 10),
        ("logging.launch", 1),
        ("parameter_handling.launch", 1),
        ("launcher_and_runner.launch", 2),
    ],
)
def test_the_original_example_launch_files_run(roscore, file, components):
    launch = roslaunch("rtcf_examples", file)
    try:
        err = wait_for(launch, "/rt_runner: running", timeout=30)
        assert err.count("/rt_runner: loaded /") == components, err
    finally:
        (err,) = end(launch)
    assert "stopped after" in err, err
    assert "Traceback" not in err, err


def test_components_read_the_parameter_server(topics):
    """ParameterHandling reads ~int_param (the launcher's private parameters) and
    public_param (relative, in its namespace) from what roslaunch set."""
    from rosgraph_msgs.msg import Log

    logs = topics.sub("/rosout_agg", Log)
    launch = roslaunch("rtcf_examples", "parameter_handling.launch")
    try:
        wait_for(launch, "/rt_runner: running", timeout=30)
        assert wait_until(lambda: any("int_param=" in m.msg for m in logs), 10.0)
    finally:
        end(launch)
    text = next(m.msg for m in logs if "int_param=" in m.msg)
    assert "int_param=33 double_param=0.56789 size=2" in text, text
    assert "another_private_param=-111222333 public_param=123.456789" in text, text
