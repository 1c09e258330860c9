"""The global /use_sim_time (what simulators set on ROS 1) drives the loop from /clock.

/clock comes from a process of its own (fixtures/clock_publisher.py), as from Gazebo.
The runner's own ~use_sim_time, when given, still rules.
"""

import sys
import time
from pathlib import Path

import pytest
import rospy
from std_msgs.msg import Float64, Int64

from .._proc import read_rest, wait_for
from ._helpers import wait_until
from ._launch import end, rt_launcher, rt_runner, start

pytestmark = pytest.mark.integration

FIXTURES = Path(__file__).parent / "fixtures"
LAUNCH = FIXTURES / "launch" / "global_sim_time.launch"
START_NS = 100 * 10**9


@pytest.fixture
def sim_topics(topics):
    """/sim/iteration and /sim/time; /use_sim_time is taken off the server afterwards
    (roslaunch and rtcf launch leave it there, and it would reach later nodes)."""
    try:
        yield topics.sub("/sim/iteration", Int64), topics.sub("/sim/time", Float64)
    finally:
        if rospy.has_param("/use_sim_time"):
            rospy.delete_param("/use_sim_time")


def clock(node, steps=21):
    """1 s of /clock time from 100 s on, in steps of 50 ms, every 20 ms of wall time;
    100 s itself held for 1 s of wall time first, so that every process of the loop
    (its lanes too) has seen it, even on a loaded machine."""
    proc = start(
        sys.executable, FIXTURES / "clock_publisher.py", START_NS, 50_000_000, steps, 0.02, node,
        1.0,
    )
    _, err = read_rest(proc)
    assert proc.returncode == 0, err


def check_follows_clock(proc, running, iterations, times):
    err = wait_for(proc, running, timeout=30)
    assert iterations.connected() and times.connected()
    time.sleep(1.0)
    # on the wall clock, 10 Hz would have run about ten iterations by now
    assert iterations == [], [m.data for m in iterations]
    clock("/rt_runner")
    # ten periods of /clock time after the first message: iterations 0 to 10
    assert wait_until(lambda: len(iterations) >= 11 and len(times) >= 11, timeout=30), (
        [m.data for m in iterations],
        [m.data for m in times],
    )
    time.sleep(1.0)  # /clock has stopped: so has the loop
    assert [m.data for m in iterations] == list(range(11))
    assert [m.data for m in times] == pytest.approx([k * 0.1 for k in range(11)])
    return err


def test_roslaunch_global_use_sim_time(sim_topics):
    iterations, times = sim_topics
    launch = start("roslaunch", "--screen", "-p", _port(), LAUNCH)
    try:
        err = check_follows_clock(launch, "/rt_runner: running", iterations, times)
        assert "on /clock time (use_sim_time)" in err
    finally:
        (err,) = end(launch)
    # (Ctrl-C reaches runner and launcher at once, so the launcher's unload may fail)
    assert "Traceback" not in err, err


def test_rtcf_launch_middleware_ros1_global_use_sim_time(sim_topics):
    iterations, times = sim_topics
    proc = start(sys.executable, "-m", "rtcf", "launch", LAUNCH, "--middleware", "ros1")
    try:
        err = check_follows_clock(proc, "running until Ctrl-C", iterations, times)
        assert "use_sim_time: true, from the global /use_sim_time" in err
    finally:
        (err,) = end(proc)
    assert "error" not in err.lower(), err


def test_the_runners_own_use_sim_time_rules(sim_topics):
    iterations, _ = sim_topics
    rospy.set_param("/use_sim_time", True)  # a simulator's, but this runner says no
    runner = rt_runner("rt_runner", use_sim_time="false", ros_mapping_whitelist="/sim/.*")
    echo = rt_launcher(
        "/rt_runner", "echo", "TimeEcho", "iteration:=/sim/iteration", "time:=/sim/time",
        package="rtcf_ros1_components",
    )
    try:
        err = wait_for(runner, "/rt_runner: running", timeout=30)
        assert "use_sim_time" not in err
        # no /clock at all: the loop runs on the wall clock
        assert wait_until(lambda: len(iterations) >= 20, timeout=10), len(iterations)
    finally:
        end(echo, runner)


def _port():
    from .conftest import PORT

    return PORT
