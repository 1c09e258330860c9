"""The arm example on ros2_controllers' controllers, from outside: ``rtcf launch
rtcf_examples arm.launch.xml ros2_controllers:=true --middleware ros2`` (one process,
MuJoCo in real time), and rclpy's ActionClient doing what MoveIt does with
``/arm_controller/follow_joint_trajectory``: a goal naming a joint the arm lacks is
rejected, a goal is followed with feedback to SUCCESSFUL, a cancel holds the arm, a
newer goal preempts the running one, and a goal whose path tolerance the arm cannot
keep is aborted with the arm holding."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
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


def _held(client, ros_node) -> np.ndarray:
    """The arm's positions over 50 /joint_states (0.5 s at 100 Hz) after now, asserting
    that they stayed put (within 0.01 rad): the last of them."""
    states: list[JointState] = []
    sub = ros_node.create_subscription(JointState, "/joint_states", states.append, 100)
    try:
        assert client.until(lambda: len(states) >= 50)
    finally:
        ros_node.destroy_subscription(sub)
    positions = np.array([s.position for s in states])
    assert np.ptp(positions, axis=0).max() < 0.01  # held, not going on to the goal
    return positions[-1]


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
    assert np.abs(_held(client, ros_node) - [-0.5, 0.4, 0.2]).max() > 0.1


def test_a_newer_goal_preempts_the_running_one(client, ros_node) -> None:
    feedback: list[Any] = []
    first = client.wait(client.send_goal_async(
        _goal({"joint1": 0.6, "joint2": -0.4, "joint3": 0.9}, seconds=3),
        feedback_callback=lambda m: feedback.append(m.feedback)))
    assert first.accepted
    assert client.until(lambda: len(feedback) >= 3)  # it runs
    second = client.wait(client.send_goal_async(
        _goal({"joint1": 0.1, "joint2": 0.2, "joint3": 0.3})))
    assert second.accepted
    answer = client.wait(first.get_result_async())
    assert answer.status == GoalStatus.STATUS_ABORTED
    assert answer.result.error_code == FollowJointTrajectory.Result.INVALID_GOAL
    assert answer.result.error_string == "Current goal preempted by new incoming action."
    answer = client.wait(second.get_result_async())
    assert answer.status == GoalStatus.STATUS_SUCCEEDED
    assert answer.result.error_code == FollowJointTrajectory.Result.SUCCESSFUL
    # the newer goal's target, not the preempted one's
    assert _held(client, ros_node) == pytest.approx([0.1, 0.2, 0.3], abs=0.02)


def test_a_path_tolerance_violated_aborts_and_the_arm_holds(client, ros_node) -> None:
    target = {"joint1": -0.4, "joint2": 0.6, "joint3": -0.2}
    start = _held(client, ros_node)  # at rest, within micro-radians of where it is held
    goal = _goal(target, seconds=2)
    # wider than the error at rest, tighter than MuJoCo's tracking error on the way
    # (several mrad): the violation comes in the motion, not in its first sample
    goal.path_tolerance = [JointTolerance(name=name, position=1e-3) for name in target]
    handle = client.wait(client.send_goal_async(goal))
    assert handle.accepted
    answer = client.wait(handle.get_result_async())
    assert answer.status == GoalStatus.STATUS_ABORTED
    assert answer.result.error_code == FollowJointTrajectory.Result.PATH_TOLERANCE_VIOLATED
    assert answer.result.error_string == "Aborted due to path tolerance violation"
    held = _held(client, ros_node)
    assert np.abs(held - start).max() > 1e-3  # it had moved: aborted on the way
    assert np.abs(held - list(target.values())).max() > 0.1  # and stopped there
