"""The arm and the diffbot as ros2_control bringups (rtcf_examples arm_bringup.launch.xml
and diffbot_bringup.launch.xml), from outside: ``rtcf launch ... --middleware ros2``
reads robot_state_publisher's description (xacro), runs its hardware in the loop
(rtcf_examples/MujocoSystem, or mock_components/GenericSystem with
``use_mock_hardware:=true``) and the spawners' controllers bound to it by key; rclpy
sends a FollowJointTrajectory goal to the arm as MoveIt does, and cmd_vel to the
diffbot as teleop does. The same controllers and YAML on both hardwares."""

from __future__ import annotations

import time

import pytest
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .._action_client import action_client
from ..test_topics import launched, spin_until

pytestmark = pytest.mark.integration

HARDWARE = {"false": "rtcf_examples/MujocoSystem", "true": "mock_components/GenericSystem"}


def _described(proc, hardware: str, plugin: str, joints: int) -> None:
    """The run took its hardware from robot_state_publisher's description."""
    assert ("robot description from robot_state_publisher /robot_state_publisher's "
            "parameter robot_description (topic /robot_description)") in proc.said
    assert f"hardware {hardware} (system, {plugin}: {joints} joints)" in proc.said


@pytest.mark.parametrize("mock", ["false", "true"], ids=["mujoco", "mock"])
def test_a_trajectory_goal_takes_the_arm_there(ros_node, mock: str) -> None:
    goal = {"joint3": 0.8, "joint1": 0.5, "joint2": -0.4}  # not in the joints' order
    states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", states.append, 10)
    with launched("rtcf_examples", "arm_bringup.launch.xml",
                  f"use_mock_hardware:={mock}") as proc:
        _described(proc, "arm", HARDWARE[mock], 3)
        with action_client(ros_node, FollowJointTrajectory,
                           "/arm_controller/follow_joint_trajectory") as client:
            assert client.until(lambda: bool(states))
            start = dict(zip(states[-1].name, states[-1].position, strict=True))
            # where the description's initial_value puts it, on both hardwares
            assert [start[j] for j in ("joint1", "joint2", "joint3")] == pytest.approx(
                [0.0, 0.3, 0.6], abs=0.01)
            request = FollowJointTrajectory.Goal(trajectory=JointTrajectory(
                joint_names=list(goal), points=[JointTrajectoryPoint(
                    positions=list(goal.values()), time_from_start=Duration(sec=1))]))
            handle = client.wait(client.send_goal_async(request))
            assert handle.accepted
            answer = client.wait(handle.get_result_async())
            assert answer.status == GoalStatus.STATUS_SUCCEEDED
            assert answer.result.error_code == FollowJointTrajectory.Result.SUCCESSFUL
            count = len(states)
            assert client.until(lambda: len(states) > count + 5)
    reached = dict(zip(states[-1].name, states[-1].position, strict=True))
    assert set(states[-1].name) == {"joint1", "joint2", "joint3"}
    assert [reached[j] for j in goal] == pytest.approx(list(goal.values()), abs=0.02)


@pytest.mark.parametrize("mock", ["false", "true"], ids=["mujoco", "mock"])
def test_cmd_vel_moves_the_diffbots_odometry(ros_node, mock: str) -> None:
    odoms: list[Odometry] = []
    states: list[JointState] = []
    ros_node.create_subscription(Odometry, "/diffbot_base_controller/odom", odoms.append, 100)
    ros_node.create_subscription(JointState, "/joint_states", states.append, 10)
    pub = ros_node.create_publisher(TwistStamped, "/diffbot_base_controller/cmd_vel", 10)
    with launched("rtcf_examples", "diffbot_bringup.launch.xml",
                  f"use_mock_hardware:={mock}") as proc:
        _described(proc, "diffbot", HARDWARE[mock], 2)
        assert spin_until(ros_node, lambda: bool(odoms) and bool(states), timeout=20)
        assert odoms[-1].pose.pose.position.x == pytest.approx(0.0, abs=1e-3)  # standing

        def teleop() -> None:  # 0.4 m/s and 0.5 rad/s, stamped now
            message = TwistStamped()
            message.header.stamp = ros_node.get_clock().now().to_msg()
            message.twist.linear.x, message.twist.angular.z = 0.4, 0.5
            pub.publish(message)

        start = time.monotonic()
        spin_until(ros_node, lambda: time.monotonic() - start > 1.5, timeout=5, publish=teleop)
        moving = odoms[-1]
    # about 1.5 s of 0.4 m/s (less the start): forward, turning left
    assert 0.3 < moving.pose.pose.position.x < 0.65
    assert moving.pose.pose.position.y > 0.01 and moving.pose.pose.orientation.z > 0.1
    assert moving.twist.twist.linear.x == pytest.approx(0.4, rel=0.05)
    assert moving.twist.twist.angular.z == pytest.approx(0.5, rel=0.05)
    # the wheels' speeds, as the hardware measured them: (v -+ w s / 2) / r
    wheels = dict(zip(states[-1].name, states[-1].velocity, strict=True))
    assert wheels["left_wheel_joint"] == pytest.approx((0.4 - 0.5 * 0.15) / 0.05, rel=0.05)
    assert wheels["right_wheel_joint"] == pytest.approx((0.4 + 0.5 * 0.15) / 0.05, rel=0.05)
