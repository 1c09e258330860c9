"""Chained controllers (issue 39): ros2_control_demos' example 16, a diff drive commanding
two pid_controllers that command the wheels' velocity on mock hardware
(fixtures/diffbot_chained.*). In-process: the chain's order, cmd_vel through the pids to
the wheels, the pids' topics ignored while chained. From outside (``rtcf launch
--middleware ros2``): list_controllers' chain fields as ros2_control fills them, a pid's
deactivation refused while the diff drive is active, its topic read again once not."""

from __future__ import annotations

from pathlib import Path

import pytest
from control_msgs.msg import MultiDOFCommand
from controller_manager_msgs.srv import ListControllers, SwitchController
from geometry_msgs.msg import TwistStamped
from sensor_msgs.msg import JointState

from rtcf.testing import run_launch

from ... import _proc
from ..conftest import rtcf_env
from ..test_parameters import call
from ..test_topics import spin_until, stop, wait_running

LAUNCH = Path(__file__).parent / "fixtures" / "diffbot_chained.launch.xml"
CM = "/controller_manager"
LEFT, RIGHT = "pid_controller_left_wheel_joint", "pid_controller_right_wheel_joint"
BASE = "diffbot_base_controller"
WHEEL = 0.1 / 0.015  # rad/s of each wheel at 0.1 m/s straight on (wheel_radius 0.015)


def _twist(x: float) -> TwistStamped:
    msg = TwistStamped()
    msg.twist.linear.x = x
    return msg


def test_cmd_vel_drives_the_wheels_through_the_pids_whose_topics_are_ignored() -> None:
    trace = run_launch(str(LAUNCH), 300, inputs={
        "/cmd_vel": _twist(0.1),
        f"/{LEFT}/reference": MultiDOFCommand(dof_names=["left_wheel_joint"], values=[42.0])})
    assert trace.result is not None
    order = trace.result.order
    assert order.index(f"/{BASE}") < order.index(f"/{LEFT}")  # preceding first
    assert order.index(f"/{BASE}") < order.index(f"/{RIGHT}")
    joints = trace.outputs["/joint_states"][-1]
    assert list(joints.name) == ["left_wheel_joint", "right_wheel_joint"]
    assert list(joints.velocity) == pytest.approx([WHEEL, WHEEL], rel=0.05)  # not 42
    state = trace.outputs[f"/{LEFT}/controller_state"][-1].dof_states[0]
    assert state.reference == pytest.approx(WHEEL)  # what the diff drive wrote (not 42)


def _controllers(node) -> dict:
    return {c.name: c for c in call(node, ListControllers, f"{CM}/list_controllers",
                                    ListControllers.Request()).controller}


def _switch(node, activate=(), deactivate=()) -> tuple[bool, str]:
    req = SwitchController.Request(activate_controllers=list(activate),
                                   deactivate_controllers=list(deactivate),
                                   strictness=SwitchController.Request.STRICT)
    res = call(node, SwitchController, f"{CM}/switch_controller", req, timeout=30)
    return res.ok, res.message


@pytest.mark.integration
def test_the_chain_as_the_controller_manager_lists_and_switches_it(ros_node) -> None:
    joints: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", joints.append, 10)
    cmd_vel = ros_node.create_publisher(TwistStamped, "/cmd_vel", 10)
    reference = ros_node.create_publisher(MultiDOFCommand, f"/{LEFT}/reference", 10)

    def left_velocity_near(value: float) -> bool:
        return bool(joints) and abs(joints[-1].velocity[0] - value) < 0.05 * abs(value)

    proc = _proc.start_rtcf(rtcf_env(), "launch", LAUNCH, "--middleware", "ros2")
    try:
        wait_running(proc, text="real-time:")
        listed = _controllers(ros_node)
        left, base = listed[LEFT], listed[BASE]
        assert (left.state, base.state) == ("active", "active")
        assert (left.is_chainable, left.is_chained) == (True, True)
        assert list(left.reference_interfaces) == ["left_wheel_joint/velocity"]
        assert list(left.claimed_interfaces) == ["left_wheel_joint/velocity"]
        assert (base.is_chainable, base.is_chained) == (True, False)
        assert list(base.reference_interfaces) == ["linear/velocity", "angular/velocity"]
        assert list(base.claimed_interfaces) == [
            f"{LEFT}/left_wheel_joint/velocity", f"{RIGHT}/right_wheel_joint/velocity"]
        both = ["left_wheel_joint/velocity", "right_wheel_joint/velocity"]  # as Jazzy lists
        assert [(c.name, list(c.reference_interfaces)) for c in base.chain_connections] == [
            (LEFT, both), (RIGHT, both)]
        assert list(left.chain_connections) == []
        assert (listed["joint_state_broadcaster"].is_chainable, listed[
            "joint_state_broadcaster"].is_chained) == (False, False)

        # cmd_vel moves the wheels through the pids; the pid's own topic is ignored
        assert spin_until(ros_node, lambda: left_velocity_near(WHEEL), timeout=10, publish=lambda: (
            cmd_vel.publish(_twist(0.1)),
            reference.publish(MultiDOFCommand(dof_names=["left_wheel_joint"], values=[3.0])))), \
            joints[-1:] or "no /joint_states"

        ok, message = _switch(ros_node, deactivate=[LEFT])
        assert not ok and (
            f"Unable to deactivate controller with name '{LEFT}' because preceding controller "
            f"with name '{BASE}' is currently active and will not be deactivated.") in message
        assert _controllers(ros_node)[LEFT].state == "active"

        # the diff drive deactivated: the pid leaves chained mode and reads its topic
        assert _switch(ros_node, deactivate=[BASE]) == (True, "")
        listed = _controllers(ros_node)
        assert (listed[BASE].state, listed[LEFT].is_chained) == ("inactive", False)
        assert spin_until(ros_node, lambda: left_velocity_near(3.0), timeout=10,
                          publish=lambda: reference.publish(MultiDOFCommand(
                              dof_names=["left_wheel_joint"], values=[3.0]))), joints[-1:]
        # and the chain switched back on in one request, chained ones first whatever the order
        assert _switch(ros_node, activate=[BASE], deactivate=[]) == (True, "")
        assert _controllers(ros_node)[LEFT].is_chained
    finally:
        stop(proc)
