"""A component at a lower rate, given by its rt_launcher's parameters (-p every:=3
-p phase:=1), on /clock time: it runs in iterations 1, 4, 7, ... at its place, and its
mapped output is published only when it was written."""

import pytest
from std_msgs.msg import Float64, Int64

from .._proc import wait_for
from ._clock import clock_publisher, step_clock
from .test_node_args import CLOCKED
from .test_nodes import STARTED, end, start
from .test_topics import spin_until

pytestmark = pytest.mark.integration


def test_a_launchers_every_and_phase_make_its_component_run_slower(ros_node, tmp_path):
    params = tmp_path / "clocked.yaml"
    params.write_text(CLOCKED)
    fast, slow, slow_t = [], [], []
    ros_node.create_subscription(Int64, "/ros/fast_it", lambda m: fast.append(m.data), 100)
    ros_node.create_subscription(Int64, "/ros/slow_it", lambda m: slow.append(m.data), 100)
    ros_node.create_subscription(Float64, "/ros/slow_t", lambda m: slow_t.append(m.data), 100)
    pub = clock_publisher(ros_node)
    r = start("rt_runner", "--ros-args", "-r", "__node:=rate_runner", "--params-file", params)
    try:
        _check(ros_node, r, pub, fast, slow, slow_t)
    finally:  # whatever happened: no process outlives the test
        end(*STARTED)
        STARTED.clear()
    assert r.returncode == 0


def _check(ros_node, r, pub, fast, slow, slow_t):
    wait_for(r, "ready: 10 Hz")
    a = start("rt_launcher", "rtcf_ros2_components", "TimeEcho", "--ros-args",
              "-r", "__node:=fast", "-p", "runner:=/rate_runner",
              "-r", "iteration:=/ros/fast_it", "-r", "time:=/ros/fast_t")
    wait_for(a, "loaded into")
    b = start("rt_launcher", "rtcf_ros2_components", "TimeEcho", "--ros-args",
              "-r", "__node:=slow", "-p", "runner:=/rate_runner", "-p", "every:=3",
              "-p", "phase:=1", "-r", "iteration:=/ros/slow_it", "-r", "time:=/ros/slow_t")
    wait_for(b, "loaded into")
    for topic in ("/ros/fast_it", "/ros/slow_it", "/ros/slow_t"):
        assert spin_until(ros_node, lambda t=topic: ros_node.count_publishers(t) > 0), topic
    assert spin_until(ros_node, lambda: ros_node.count_subscribers("/clock") > 0)
    step_clock(ros_node, pub, fast, periods=10)  # 1 s of /clock
    assert fast == list(range(11))
    # every 3 iterations from phase 1, and published only in those
    assert slow == [1, 4, 7, 10]
    assert slow_t == pytest.approx([0.1, 0.4, 0.7, 1.0])
    end(b, a, r)
