"""A ros2_control robot that runs from its own description, from outside: ``rtcf launch
--middleware ros2`` of hardware.launch.xml (a URDF with mock_components/GenericSystem,
a trajectory controller on the arm, a forward controller on the gripper, no remaps); an
rclpy client calls the controller manager's services as ``ros2 control`` does."""

from __future__ import annotations

from pathlib import Path

import pytest
from controller_manager_msgs.srv import (
    ListControllers,
    ListHardwareComponents,
    ListHardwareInterfaces,
    SetHardwareComponentState,
    SwitchController,
)
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ... import _proc
from ..conftest import rtcf_env
from ..test_parameters import call
from ..test_topics import spin_until, stop, wait_running

pytestmark = pytest.mark.integration

LAUNCH = Path(__file__).parent / "fixtures" / "hardware.launch.xml"
CM = "/controller_manager"


def _switch(node, activate=(), deactivate=()) -> tuple[bool, str]:
    req = SwitchController.Request(activate_controllers=list(activate),
                                   deactivate_controllers=list(deactivate),
                                   strictness=SwitchController.Request.STRICT)
    res = call(node, SwitchController, f"{CM}/switch_controller", req, timeout=30)
    return res.ok, res.message


def test_a_robot_runs_from_its_description_with_mock_hardware(ros_node) -> None:
    joint_states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", joint_states.append, 10)
    gripper = ros_node.create_publisher(Float64MultiArray, "/gripper_controller/commands", 10)
    proc = _proc.start_rtcf(rtcf_env(), "launch", LAUNCH, "--middleware", "ros2")
    try:
        wait_running(proc, text="real-time:")
        controllers = {c.name: c for c in call(
            ros_node, ListControllers, f"{CM}/list_controllers",
            ListControllers.Request()).controller}
        arm, grip = controllers["arm_controller"], controllers["gripper_controller"]
        assert (arm.state, grip.state) == ("active", "active")  # one hardware, both run
        assert list(arm.claimed_interfaces) == [f"joint{i}/position" for i in (1, 2, 3)]
        assert list(arm.required_state_interfaces) == sorted(
            f"joint{i}/{s}" for i in (1, 2, 3) for s in ("position", "velocity"))
        assert list(grip.claimed_interfaces) == ["gripper_joint/position"]
        assert controllers["typo_controller"].state == "inactive"

        # the hardware, as the controller manager lists it
        hardware = call(ros_node, ListHardwareComponents, f"{CM}/list_hardware_components",
                        ListHardwareComponents.Request()).component
        assert [(h.name, h.type, h.plugin_name, h.state.label) for h in hardware] == [
            ("arm", "system", "mock_components/GenericSystem", "active")]
        interfaces = call(ros_node, ListHardwareInterfaces, f"{CM}/list_hardware_interfaces",
                          ListHardwareInterfaces.Request())
        assert [(i.name, i.is_available, i.is_claimed) for i in interfaces.command_interfaces] \
            == [("gripper_joint/position", True, True)] + [
                (f"joint{i}/position", True, True) for i in (1, 2, 3)]
        assert len(interfaces.state_interfaces) == 8

        # a command reaches the state (GenericSystem mirrors it): no remap anywhere
        assert spin_until(ros_node, lambda: bool(joint_states) and abs(dict(zip(
            joint_states[-1].name, joint_states[-1].position, strict=True)).get(
            "gripper_joint", 0.0) - 0.03) < 1e-9,
            publish=lambda: gripper.publish(Float64MultiArray(data=[0.03]))), \
            "the gripper's command did not reach its state"

        # claims per key: a third controller on a claimed joint, and a typo, refused
        ok, message = _switch(ros_node, activate=["other_controller"])
        assert not ok and message.startswith(
            "Could not activate controller 'other_controller': Unable to activate controller "
            "'other_controller' since the command interface 'joint3/position' is currently "
            "claimed by another controller. (by 'arm_controller')")
        ok, message = _switch(ros_node, activate=["typo_controller"])
        assert not ok and message.startswith(
            "Could not activate controller 'typo_controller': Unable to activate controller "
            "'typo_controller' "
            "since the command interface 'gripper_joint/positon' is not available. (no "
            "hardware component exports it; did you mean 'gripper_joint/position'?)")

        # the hardware's state, set while the loop runs
        req = SetHardwareComponentState.Request(name="arm")
        req.target_state.label = "inactive"
        res = call(ros_node, SetHardwareComponentState, f"{CM}/set_hardware_component_state",
                   req)
        assert (res.ok, res.state.label) == (True, "inactive")
        hardware = call(ros_node, ListHardwareComponents, f"{CM}/list_hardware_components",
                        ListHardwareComponents.Request()).component
        assert hardware[0].state.label == "inactive"
    finally:
        stop(proc)


def test_rtcf_check_names_what_the_controller_manager_would_refuse(tmp_path) -> None:
    """Before anything runs: the typo is an interface no hardware exports, and two
    controllers that start active on one joint would both claim it."""
    import subprocess
    import sys

    text = LAUNCH.read_text()
    ok = subprocess.run([sys.executable, "-m", "rtcf", "check", str(LAUNCH)],
                        capture_output=True, text=True, env=rtcf_env(), timeout=120)
    assert ok.returncode == 1
    assert ok.stderr.strip().splitlines()[-1].endswith(
        "Unable to activate controller 'typo_controller' since the command interface "
        "'gripper_joint/positon' is not available. (no hardware component exports it; did "
        "you mean 'gripper_joint/position'?)"), ok.stderr
    # other_controller (on joint3, like arm_controller) made to start active too
    both = tmp_path / "hardware_both_active.launch.xml"
    both.write_text(text.replace("$(dirname)", str(LAUNCH.parent)).replace(
        '<param name="autostart" value="false"/>\n  </node>\n  <node pkg="rtcf" '
        'exec="rt_launcher" name="typo_controller"',
        '</node>\n  <node pkg="rtcf" exec="rt_launcher" name="typo_controller"', 1))
    assert both.read_text().count('"autostart"') == 1
    clash = subprocess.run([sys.executable, "-m", "rtcf", "check", str(both)],
                           capture_output=True, text=True, env=rtcf_env(), timeout=120)
    assert clash.returncode == 1
    assert "'joint3/position' will be used by another controller that is being activated" \
        in clash.stderr, clash.stderr
