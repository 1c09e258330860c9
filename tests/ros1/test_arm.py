"""The arm example on ROS 1 (rtcf_examples arm.launch ros_interfaces:=true, with
roslaunch and with rtcf launch --middleware ros1): sensor_msgs/JointState on
/joint_states at 100 Hz stamped on the loop's grid, from the broadcaster's lane of its
own, and a trajectory_msgs/JointTrajectory published by this process on
/arm_controller/joint_trajectory is followed, its joints in any order; one that cannot
be followed is logged and ignored."""

import re

import numpy as np
import pytest
import rospy
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import JointState  # fails loudly where it is missing
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, roslaunch, rtcf_launch

pytestmark = pytest.mark.integration

GOAL = {"joint1": 0.5, "joint2": -0.2, "joint3": 0.8}


@pytest.mark.parametrize("start", [roslaunch, rtcf_launch], ids=["roslaunch", "rtcf_launch"])
def test_joint_states_go_out_and_a_trajectory_sent_is_followed(topics, start):
    proc = start("rtcf_examples", "arm.launch", "ros_interfaces:=true")
    try:
        said = wait_for(proc, "running", timeout=60)
        # the broadcaster in its own lane (rt_runner and rtcf launch each say it their way)
        assert re.search(r"ros_io \(LET, every 10|JointStateBroadcaster\) in lane 'ros_io'",
                         said), said
        states = topics.sub("/joint_states", JointState, queue_size=1000)
        # the trajectory's log, as rqt_console sees it
        logs = topics.sub("/rosout_agg", Log, queue_size=1000)
        pub = topics.pub("/arm_controller/joint_trajectory", JointTrajectory)
        assert wait_until(lambda: len(states) >= 100, timeout=30), len(states)
        first = states[0]
        assert list(first.name) == ["joint1", "joint2", "joint3"]
        assert len(first.position) == len(first.velocity) == len(first.effort) == 3
        stamps = np.array([m.header.stamp.to_sec() for m in states])
        steps = np.diff(stamps)
        # one every 10 ms of the loop's grid (the iteration's stamp, not the arrival)
        assert np.median(steps) == pytest.approx(0.010, abs=1e-6), steps
        assert np.all(steps > 0)
        # a bad one first: ignored, logged, the plan goes on
        bad = JointTrajectory(joint_names=["elbow"], points=[
            JointTrajectoryPoint(positions=[1.0], time_from_start=rospy.Duration(1))])
        wait_until(lambda: False, timeout=1.0, publish=lambda: pub.publish(bad), every=0.2)
        names = ["joint3", "joint1", "joint2"]
        sent = JointTrajectory(joint_names=names, points=[JointTrajectoryPoint(
            positions=[GOAL[n] for n in names], time_from_start=rospy.Duration(1))])
        goal = np.array([GOAL["joint1"], GOAL["joint2"], GOAL["joint3"]])
        published = [False]

        def send_once():  # a new trajectory replaces the plan: send it once it is heard
            if not published[0] and pub.get_num_connections() > 0:
                pub.publish(sent)
                published[0] = True

        assert wait_until(
            lambda: np.abs(np.array(states[-1].position) - goal).max() < 5e-3,
            timeout=30, publish=send_once,
        ), states[-1].position
        count = len(states)
        assert wait_until(lambda: len(states) > count + 50, timeout=10)
        assert all(np.abs(np.array(m.position) - goal).max() < 5e-3 for m in states[-50:])
        said = lambda: [r.msg for r in logs if r.name == "/arm/trajectory"]  # noqa: E731
        assert wait_until(lambda: any(
            m.startswith("following a trajectory of 1 points over 1.00 s") for m in said())
        ), said()
        bad_seen = [m for m in said() if m.startswith("joint_trajectory ignored")]
        assert bad_seen and "its joint_names ['elbow'] are not" in bad_seen[0], said()
    finally:
        (err,) = end(proc)
    assert "Traceback" not in err, err
