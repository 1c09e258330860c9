"""use_sim_time: /clock drives the loop, one iteration per period of /clock time."""

import textwrap
import time

import pytest
from std_msgs.msg import Float64, Int64

from .._launches import launch_xml, runner_xml
from ._clock import clock_msg, clock_publisher
from .conftest import start_rtcf
from .test_topics import spin_until, stop, wait_running

pytestmark = pytest.mark.integration

LAUNCH = launch_xml("""
  <node name="echo" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components TimeEcho">
    <remap from="iteration" to="/ros/iteration"/>
    <remap from="time" to="/ros/time"/>
  </node>
""", runner_xml(10.0, use_sim_time="true", ros_mapping_whitelist="/ros/.*"))


def test_clock_steps_the_loop_and_the_loop_waits_when_it_stops(ros_node, tmp_path):
    path = tmp_path / "sim.launch"
    path.write_text(textwrap.dedent(LAUNCH))
    iterations, times = [], []
    ros_node.create_subscription(Int64, "/ros/iteration", lambda m: iterations.append(m.data), 100)
    ros_node.create_subscription(Float64, "/ros/time", lambda m: times.append(m.data), 100)
    pub = clock_publisher(ros_node)
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    try:
        wait_running(proc)
        assert spin_until(ros_node, lambda: ros_node.count_subscribers("/clock") > 0)
        assert spin_until(ros_node, lambda: ros_node.count_publishers("/ros/iteration") > 0)
        assert iterations == []  # nothing runs before the first /clock
        start = 100 * 10**9
        # the first /clock again and again until it arrived (best effort: discovery may
        # still be matching the two sides); the same time does not advance the loop
        assert spin_until(
            ros_node, lambda: iterations == [0], publish=lambda: pub.publish(clock_msg(start))
        ), iterations
        # 1 s of /clock time in steps of 50 ms: ten periods at 10 Hz
        for k in range(1, 21):
            pub.publish(clock_msg(start + k * 50_000_000))
            spin_until(ros_node, lambda: False, timeout=0.05)
        assert spin_until(ros_node, lambda: bool(iterations) and iterations[-1] == 10)
        assert iterations == list(range(11))
        assert times == pytest.approx([i * 0.1 for i in range(11)])
        # /clock stops: so does the loop
        spin_until(ros_node, lambda: False, timeout=1.0)
        assert iterations[-1] == 10
        # one more period of /clock time: one more iteration
        pub.publish(clock_msg(start + 1_100_000_000))
        assert spin_until(ros_node, lambda: iterations[-1] == 11)
        time.sleep(0.2)
    finally:
        _, err = stop(proc)
    assert "error" not in err.lower(), err
