"""The arm example on ros2_controllers' controllers, from outside: ``rtcf launch
rtcf_examples arm.launch.xml ros2_controllers:=true --middleware ros2`` (one process,
MuJoCo in real time), and rclpy's ActionClient doing what MoveIt does with
``/arm_controller/follow_joint_trajectory``: a goal naming a joint the arm lacks is
rejected, a goal is followed with feedback to SUCCESSFUL, and a cancel holds the arm."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .._action_client import action_client
from ..test_topics import launched

pytestmark = pytest.mark.integration

NAME = "/arm_controller/follow_joint_trajectory"


@pytest.fixture(scope="module")
def arm():
    with launched("rtcf_examples", "arm.launch.xml", "ros2_controllers:=true") as proc:
        yield proc


@pytest.fixture
def client(arm, ros_node):
    with action_client(ros_node, FollowJointTrajectory, NAME) as client:
        yield client


def _goal(positions: dict[str, float], seconds: int = 1) -> FollowJointTrajectory.Goal:
    return FollowJointTrajectory.Goal(trajectory=JointTrajectory(
        joint_names=list(positions),
        points=[JointTrajectoryPoint(positions=list(positions.values()),
                                     time_from_start=Duration(sec=seconds))]))


def test_a_goal_naming_an_unknown_joint_is_rejected(client) -> None:
    assert not client.wait(client.send_goal_async(_goal({"joint1": 0.1, "elbow": 0.2}))).accepted


def test_a_goal_is_followed_with_feedback_to_success(client, ros_node) -> None:
    feedback: list[Any] = []
    target = {"joint3": 0.8, "joint1": 0.5, "joint2": -0.2}
    handle = client.wait(client.send_goal_async(
        _goal(target), feedback_callback=lambda m: feedback.append(m.feedback)))
    assert handle.accepted
    answer = client.wait(handle.get_result_async())
    assert answer.status == GoalStatus.STATUS_SUCCEEDED
    assert answer.result.error_code == FollowJointTrajectory.Result.SUCCESSFUL
    assert feedback and list(feedback[-1].joint_names) == ["joint1", "joint2", "joint3"]
    states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", states.append, 10)
    assert client.until(lambda: bool(states))
    reached = np.array(states[-1].position)
    assert reached == pytest.approx([0.5, -0.2, 0.8], abs=0.02)


def test_a_cancel_ends_the_goal_and_holds_the_arm(client, ros_node) -> None:
    feedback: list[Any] = []
    handle = client.wait(client.send_goal_async(
        _goal({"joint1": -0.5, "joint2": 0.4, "joint3": 0.2}, seconds=3),
        feedback_callback=lambda m: feedback.append(m.feedback)))
    assert handle.accepted
    assert client.until(lambda: len(feedback) >= 5)  # on its way (20 Hz)
    client.wait(handle.cancel_goal_async())
    answer = client.wait(handle.get_result_async())
    assert answer.status == GoalStatus.STATUS_CANCELED
    states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", states.append, 100)
    assert client.until(lambda: len(states) >= 50)
    first, last = np.array(states[0].position), np.array(states[-1].position)
    assert np.abs(last - first).max() < 0.01  # held, not going on to the goal
    assert np.abs(last - [-0.5, 0.4, 0.2]).max() > 0.1
