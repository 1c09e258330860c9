"""use_sim_time: /clock drives the loop, one iteration per period of /clock time."""

import time

import pytest
import rospy
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, Int64

from ._helpers import stop, wait_running, wait_until
from .conftest import start_runner

pytestmark = pytest.mark.integration

ECHO = {
    "name": "echo",
    "module": "rtcf_ros1_components",
    "class": "TimeEcho",
    "remaps": {"iteration": "/ros/iteration", "time": "/ros/time"},
}


def clock_msg(ns):
    return Clock(clock=rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000))


def test_clock_steps_the_loop_and_the_loop_waits_when_it_stops(topics):
    iterations = topics.sub("/ros/iteration", Int64)
    times = topics.sub("/ros/time", Float64)
    clock = topics.pub("/clock", Clock, queue_size=100)
    proc = start_runner(
        [ECHO], frequency=10.0, use_sim_time=True, ros_mapping_whitelist="/ros/.*"
    )
    try:
        wait_running(proc)
        assert wait_until(lambda: clock.get_num_connections() > 0)
        assert iterations.connected() and times.connected()
        time.sleep(0.3)
        assert iterations == []  # nothing runs before the first /clock
        start = 100 * 10**9
        # 1 s of /clock time in steps of 50 ms: ten periods at 10 Hz
        for k in range(21):
            clock.publish(clock_msg(start + k * 50_000_000))
            time.sleep(0.05)
        assert wait_until(lambda: bool(iterations) and iterations[-1].data == 10)
        assert [m.data for m in iterations] == list(range(11))
        assert wait_until(lambda: len(times) == 11)
        assert [m.data for m in times] == pytest.approx([i * 0.1 for i in range(11)])
        # /clock stops: so does the loop
        time.sleep(1.0)
        assert iterations[-1].data == 10
        # one more period of /clock time: one more iteration
        clock.publish(clock_msg(start + 1_100_000_000))
        assert wait_until(lambda: iterations[-1].data == 11)
    finally:
        _, err = stop(proc)
    assert "error" not in err.lower(), err
