"""A component at a lower rate under roslaunch: its rt_launcher's private parameters
every and phase, on /clock time. It runs in iterations 1, 4, 7, 10 at its place, and
its mapped outputs are published only in those."""

import re
import time

import pytest
import rospy
from std_msgs.msg import Float64, Int64

from ._helpers import wait_until
from ._launch import end, start
from .test_global_sim_time import FIXTURES, _port, clock

pytestmark = pytest.mark.integration

LAUNCH = FIXTURES / "launch" / "rates.launch"


@pytest.mark.parametrize("lanes", [False, True], ids=["one lane", "lanes"])
def test_roslaunch_every_and_phase_on_a_launcher(topics, tmp_path, lanes):
    launch_file = LAUNCH
    if lanes:  # the echo in a lock-step lane, the slow one on logical execution time:
        # each a worker process of its own, on /clock time, with the same values
        text = LAUNCH.read_text()
        for node, lane in (("echo", "right"), ("slow_echo", "plan")):
            text = text.replace(f'<node name="{node}" pkg="rtcf" type="rt_launcher"',
                                f'<node name="{node}" pkg="rtcf" type="rt_launcher" '
                                f'lane_placeholder="{lane}"', 1)
        text = re.sub(r'(<node [^>]*) lane_placeholder="(\w+)"([^>]*>)',
                      r'\1\3<param name="lane" value="\2"/>', text)
        assert text.count('name="lane"') == 2, text
        launch_file = tmp_path / "rates_lanes.launch"
        launch_file.write_text(text)
    iterations = topics.sub("/sim/iteration", Int64)
    slow = topics.sub("/slow/iteration", Int64)
    slow_t = topics.sub("/slow/time", Float64)
    launch = start("roslaunch", "--screen", "-p", _port(), launch_file)
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
