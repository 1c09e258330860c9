"""The controller manager's services from outside: an rclpy client in this process calls
``/controller_manager/list_controllers`` and ``switch_controller`` of an ``rtcf launch
--middleware ros2`` of the controllers' example (simple.launch.xml, configured by its
ros2_controllers YAML file), as ``ros2 control`` and rqt_controller_manager do; and a
publisher of ``/forward_position_controller/commands`` whose command of the wrong length
is refused."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from controller_manager_msgs.srv import ListControllers, SwitchController
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from ... import _proc
from ..conftest import rtcf_env
from ..test_parameters import call
from ..test_topics import spin_until, stop, wait_running

pytestmark = pytest.mark.integration

ROOT = Path(__file__).parents[3]  # the fixture's hardware is tests.ros2.controllers._plants
LAUNCH = Path(__file__).parent / "fixtures" / "simple.launch.xml"
STRICT, BEST_EFFORT = SwitchController.Request.STRICT, SwitchController.Request.BEST_EFFORT


def _list(node) -> dict[str, tuple[str, str, int, bool]]:
    res = call(node, ListControllers, "/controller_manager/list_controllers",
               ListControllers.Request())
    return {c.name: (c.state, c.type, c.update_rate, c.is_async) for c in res.controller}


def _switch(node, activate=(), deactivate=(), strictness=STRICT) -> tuple[bool, str]:
    req = SwitchController.Request(activate_controllers=list(activate),
                                   deactivate_controllers=list(deactivate),
                                   strictness=strictness)
    res = call(node, SwitchController, "/controller_manager/switch_controller", req, timeout=30)
    return res.ok, res.message


def _states(node) -> dict[str, str]:
    return {name: row[0] for name, row in _list(node).items()}


# the example, a controller that cannot be activated again once deactivated, and one
# that says when it starts and stops
WITH_REFUSER = """<launch>
  <include file="{launch}">
    <arg name="frequency" value="200.0"/>
    <arg name="ros_topics" value="/joint_states|/forward_position_controller/commands"/>
  </include>
  <node pkg="rtcf" exec="rt_launcher" name="refuser"
        args="tests.ros2.controllers._plants RefusesRestart"/>
  <node pkg="rtcf" exec="rt_launcher" name="standby"
        args="tests.ros2.controllers._plants SaysWhen"/>
</launch>
"""


def test_list_controllers_and_switch_one_off_while_the_others_run(ros_node, tmp_path) -> None:
    env = rtcf_env()
    env["PYTHONPATH"] = f"{ROOT}:{env['PYTHONPATH']}"
    joint_states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", joint_states.append, 10)
    records: list[Log] = []
    ros_node.create_subscription(Log, "/rosout", records.append, QoSProfile(
        depth=1000, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL))
    commands = ros_node.create_publisher(
        Float64MultiArray, "/forward_position_controller/commands", 10)
    launch = tmp_path / "cm.launch.xml"
    launch.write_text(WITH_REFUSER.format(launch=LAUNCH))
    proc = _proc.start_rtcf(env, "launch", launch, "--middleware", "ros2")
    try:
        # the components start when the loop does, after "running until Ctrl-C"
        wait_running(proc, text="real-time:")
        listed = _list(ros_node)
        assert listed.pop("refuser") == (
            "active", "tests.ros2.controllers._plants.RefusesRestart", 200, False)
        assert listed.pop("standby") == (
            "active", "tests.ros2.controllers._plants.SaysWhen", 200, False)
        assert listed == {
            "arm/hardware": ("active", "tests.ros2.controllers._plants.PositionJoints", 200,
                             False),
            "wheel/hardware": ("active", "tests.ros2.controllers._plants.Mass", 200, False),
            "joint_state_broadcaster": (
                "active", "joint_state_broadcaster/JointStateBroadcaster", 100, False),
            "forward_position_controller": (
                "active", "forward_command_controller/ForwardCommandController", 200, False),
            "arm_effort_controller": (
                "active", "effort_controllers/JointGroupEffortController", 200, False),
            "wheel_pid_controller": ("active", "pid_controller/PidController", 200, False),
            "head/hardware": ("active", "tests.ros2.controllers._plants.PositionJoints", 200,
                              False),
            "base/hardware": ("active", "tests.ros2.controllers._plants.VelocityJoints", 200,
                              False),
            "head_controller": (
                "active", "joint_trajectory_controller/JointTrajectoryController", 200, False),
            "base_controller": (
                "active", "diff_drive_controller/DiffDriveController", 200, False),
        }

        # a command of the wrong length is refused, logged with the lengths, and the
        # arm stays where it starts (no command yet); one of the right length moves it
        refused = lambda: [r for r in records if "commands refused" in r.msg]  # noqa: E731
        assert spin_until(ros_node, refused, publish=lambda: commands.publish(
            Float64MultiArray(data=[1.0, 1.0]))), "no refusal on /rosout"
        assert refused()[0].msg == ("/forward_position_controller/commands refused: 2 values "
                                    "for 3 joints (joint1, joint2, joint3); the last command "
                                    "stays")
        joint_states.clear()
        assert spin_until(ros_node, lambda: len(joint_states) >= 3), "no /joint_states"
        assert list(joint_states[-1].position[:3]) == [0.0, 0.3, 0.6]
        right = [0.2, -0.1, 0.4]
        assert spin_until(ros_node, lambda: bool(joint_states) and list(
            joint_states[-1].position[:3]) == right, publish=lambda: commands.publish(
            Float64MultiArray(data=right))), "the right-length command did not move the arm"

        # STRICT with a name that does not exist: refused, nothing switched
        ok, message = _switch(ros_node, deactivate=["forward_position_controller", "nope"])
        assert (ok, message) == (False, "Could not deactivate controller with name 'nope' "
                                        "because no controller with this name exists")
        assert _states(ros_node)["forward_position_controller"] == "active"

        # one off: it alone is inactive, and the broadcaster goes on publishing
        assert _switch(ros_node, deactivate=["forward_position_controller"]) == (True, "")
        states = _states(ros_node)
        assert states.pop("forward_position_controller") == "inactive"
        assert set(states.values()) == {"active"}
        joint_states.clear()
        assert spin_until(ros_node, lambda: len(joint_states) >= 5), "no /joint_states"

        # STRICT refuses to activate one that is active already; BEST_EFFORT leaves it
        # (and an unknown name) out and activates the rest
        ok, message = _switch(ros_node, activate=["forward_position_controller",
                                                  "joint_state_broadcaster"])
        assert (ok, message) == (False, "Controller with name 'joint_state_broadcaster' is "
                                        "already active.")
        assert _states(ros_node)["forward_position_controller"] == "inactive"
        ok, _ = _switch(ros_node, activate=["forward_position_controller",
                                            "joint_state_broadcaster", "nope"],
                        strictness=BEST_EFFORT)
        assert ok
        assert set(_states(ros_node).values()) == {"active"}

        # a switch from one to the other lands in one iteration: the one stops and the
        # other starts at the start of the same iteration, the stop first
        assert _switch(ros_node, deactivate=["standby"]) == (True, "")
        assert _switch(ros_node, deactivate=["refuser"], activate=["standby"]) == (True, "")

        # STRICT: a transition that fails undoes the switch (the PID comes back on)
        ok, message = _switch(ros_node, activate=["refuser"],
                              deactivate=["wheel_pid_controller"])
        assert (ok, message) == (False, "Could not activate controller 'refuser': start() "
                                        "returned False; the switch was undone ('STRICT' switch)")
        states = _states(ros_node)
        assert (states.pop("refuser"), set(states.values())) == ("inactive", {"active"})
    finally:
        _, err = stop(proc)
    assert "[/forward_position_controller]: lifecycle: deactivate: active -> inactive" in err
    hooks = re.findall(r"\[/(refuser|standby)\]: (start|stop) at iteration (-?\d+)", err)
    # each started before the loop's first iteration; standby stopped; then the switch;
    # then refuser's failed start (no stop at the shutdown: it is inactive)
    switch = [(who, hook) for who, hook, _ in hooks[2:5]]
    assert switch == [("standby", "stop"), ("refuser", "stop"), ("standby", "start")]
    assert hooks[3][2] == hooks[4][2], hooks  # the same iteration
