"""Lanes under ROS 2: a launcher's ``-p lane:=NAME`` puts its component in a worker
process of its own; its mapped outputs are published, and a mapped input that
components in several lanes read reaches each of them."""

import signal

import pytest
from std_msgs.msg import Float64

from .._proc import read_rest, wait_for
from .test_nodes import end, runner, start
from .test_topics import spin_until

pytestmark = pytest.mark.integration


def lane_launcher(name, lane, *remaps):
    args = ["rtcf_examples", "Mimo", "--ros-args", "-r", f"__node:={name}",
            "-p", "runner:=/lane_runner"]
    if lane:
        args += ["-p", f"lane:={lane}"]
    for rule in remaps:
        args += ["-r", rule]
    return start("rt_launcher", *args)


def test_a_lane_publishes_its_outputs_and_reads_what_ros_publishes(ros_node):
    r = runner("lane_runner")
    try:
        wait_for(r, "ready")
        # /ros/lin: read in the main lane (a) and in lane "right" (b); /ros/lout: b's
        a = lane_launcher("la", "", "-r", "in1:=/ros/lin", "-r", "in2:=/ros/lin",
                          "-r", "out1:=/lmid")
        wait_for(a, "loaded into")
        b = lane_launcher("lb", "right", "-r", "in1:=/lmid", "-r", "in2:=/ros/lin",
                          "-r", "out1:=/ros/lout")
        wait_for(b, "loaded into")
        got = []
        ros_node.create_subscription(Float64, "/ros/lout", lambda m: got.append(m.data), 10)
        pub = ros_node.create_publisher(Float64, "/ros/lin", 10)
        for x in (7.0, -2.5):
            assert spin_until(
                ros_node,
                lambda x=x: bool(got) and got[-1] == pytest.approx(3 * x),
                publish=lambda x=x: pub.publish(Float64(data=x)),
            ), got[-3:]
        end(b)
        wait_for(r, "unloaded /lb")
        end(a)
        wait_for(r, "unloaded /la")
        r.send_signal(signal.SIGINT)
        _, err = read_rest(r)
    finally:
        end(r)
    assert r.returncode == 0, err
    assert "lane 'right' runs in a worker process of its own" in err, err[-3000:]
