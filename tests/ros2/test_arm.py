"""The arm example on ROS 2 (rtcf_examples arm.launch ros_interfaces:=true, --middleware
ros2): sensor_msgs/JointState on /joint_states at 100 Hz stamped on the loop's grid,
and a trajectory_msgs/JointTrajectory sent from this process to
/arm_controller/joint_trajectory (joint_trajectory_controller's topic) is followed: the
arm reaches its goal. A trajectory that cannot be followed is logged and ignored."""


import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from sensor_msgs.msg import JointState  # fails loudly where it is missing
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .._proc import interrupt, wait_for
from .conftest import start_rtcf
from .test_topics import spin_until

pytestmark = pytest.mark.integration

GOAL = {"joint1": 0.5, "joint2": -0.2, "joint3": 0.8}


@pytest.mark.parametrize("file", ["arm.launch", "arm.launch.xml"])
def test_joint_states_go_out_and_a_trajectory_sent_is_followed(ros_node, file):
    proc = start_rtcf("launch", "rtcf_examples", file, "ros_interfaces:=true",
                      "--middleware", "ros2")
    try:
        wait_for(proc, "running until Ctrl-C", timeout=60)
        states = []
        ros_node.create_subscription(JointState, "/joint_states", states.append, 1000)
        pub = ros_node.create_publisher(
            JointTrajectory, "/arm_controller/joint_trajectory", 10)
        assert spin_until(ros_node, lambda: len(states) >= 100, timeout=30)
        first = states[0]
        assert list(first.name) == ["joint1", "joint2", "joint3"]
        assert len(first.position) == len(first.velocity) == len(first.effort) == 3
        stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
                           for m in states])
        steps = np.diff(stamps)
        # one every 10 ms of the loop's grid (the iteration's stamp, not the arrival)
        assert np.median(steps) == pytest.approx(0.010, abs=1e-6), steps
        assert np.all(steps > 0)
        # a bad one first: ignored, logged, the plan goes on
        bad = JointTrajectory(joint_names=["elbow"], points=[
            JointTrajectoryPoint(positions=[1.0], time_from_start=Duration(sec=1))])
        spin_until(ros_node, lambda: False, timeout=1.0, publish=lambda: pub.publish(bad))
        # the joints in another order than the model's, as any client may send them
        names = ["joint3", "joint1", "joint2"]
        sent = JointTrajectory(joint_names=names, points=[JointTrajectoryPoint(
            positions=[GOAL[n] for n in names], time_from_start=Duration(sec=1))])
        goal = np.array([GOAL["joint1"], GOAL["joint2"], GOAL["joint3"]])

        def reached():
            last = states[-1]
            return np.abs(np.array(last.position) - goal).max() < 5e-3

        assert spin_until(ros_node, reached, timeout=30, publish=lambda: (
            None if len(states) % 50 else pub.publish(sent))), states[-1].position
        # and it stays there (it holds the last point)
        count = len(states)
        assert spin_until(ros_node, lambda: len(states) > count + 50, timeout=10)
        assert all(np.abs(np.array(m.position) - goal).max() < 5e-3 for m in states[-50:])
        types = dict(ros_node.get_topic_names_and_types())
        assert types["/joint_states"] == ["sensor_msgs/msg/JointState"]
    finally:
        _, err = interrupt(proc)
    assert proc.returncode == 0, err
    assert "Found remap rule" not in err, err  # launch arguments are not rclpy's remaps
    assert "joint_trajectory ignored: its joint_names ['elbow'] are not" in err, err
    assert "following a trajectory of 1 points over 1.00 s" in err
