"""A component at a lower rate under roslaunch: its rt_launcher's private parameters
every and phase, on /clock time. It runs in iterations 1, 4, 7, 10 at its place, and
its mapped outputs are published only in those."""

import time

import pytest
import rospy
from std_msgs.msg import Float64, Int64

from ._helpers import wait_until
from ._launch import end, start
from .test_global_sim_time import FIXTURES, _port, clock

pytestmark = pytest.mark.integration

LAUNCH = FIXTURES / "launch" / "rates.launch"


def test_roslaunch_every_and_phase_on_a_launcher(topics):
    iterations = topics.sub("/sim/iteration", Int64)
    slow = topics.sub("/slow/iteration", Int64)
    slow_t = topics.sub("/slow/time", Float64)
    launch = start("roslaunch", "--screen", "-p", _port(), LAUNCH)
    try:
        from .._proc import wait_for

        wait_for(launch, "/rt_runner: running", timeout=30)
        assert iterations.connected() and slow.connected() and slow_t.connected()
        clock("/rt_runner")  # 1 s of /clock: iterations 0 to 10
        # generous: a loaded CI machine delays the launch's nodes, not the values
        assert wait_until(lambda: len(iterations) >= 11 and len(slow_t) >= 4, timeout=30), (
            [m.data for m in iterations],
            [m.data for m in slow],
            [m.data for m in slow_t],
        )
        time.sleep(1.0)
        assert [m.data for m in iterations] == list(range(11))
        assert [m.data for m in slow] == [1, 4, 7, 10]
        assert [m.data for m in slow_t] == pytest.approx([0.1, 0.4, 0.7, 1.0])
    finally:
        (err,) = end(launch)
        if rospy.has_param("/use_sim_time"):
            rospy.delete_param("/use_sim_time")
    assert "Traceback" not in err, err
