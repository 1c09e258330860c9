"""The controller manager's services from outside: an rclpy client in this process calls
``/controller_manager/list_controllers`` and ``switch_controller`` of an ``rtcf launch
--middleware ros2`` of the controllers' example (simple.launch.xml, configured by its
ros2_controllers YAML file), as ``ros2 control`` and rqt_controller_manager do; and a
publisher of ``/forward_position_controller/commands`` whose command of the wrong length
is refused; and two controllers claiming one command topic (a bringup's spawners, one
``--inactive``) between which a switch moves the claim."""

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


def _env_and_joint_states(node) -> tuple[dict[str, str], list[JointState]]:
    """The launch's environment (the fixtures' hardware importable), and the
    /joint_states that ``node`` receives."""
    env = rtcf_env()
    env["PYTHONPATH"] = f"{ROOT}:{env['PYTHONPATH']}"
    joint_states: list[JointState] = []
    node.create_subscription(JointState, "/joint_states", joint_states.append, 10)
    return env, joint_states


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
    env, joint_states = _env_and_joint_states(ros_node)
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


# two controllers claiming the arm's position_command, as a bringup spawns them: one
# active, the other --inactive
CLAIMS_YAML = """controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    forward_position_controller: {type: forward_command_controller/ForwardCommandController}
    arm_teleop: {type: position_controllers/JointGroupPositionController}
joint_state_broadcaster:
  ros__parameters: {joints: [joint1, joint2, joint3], interfaces: [position]}
forward_position_controller:
  ros__parameters: {joints: [joint1, joint2, joint3], interface_name: position}
arm_teleop:
  ros__parameters: {joints: [joint1, joint2, joint3]}
"""
CLAIMS = """<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="mode" value="no_wait"/>
    <param name="ros_mapping_whitelist"
           value="/joint_states|/forward_position_controller/commands|/arm_teleop/commands"/>
    <param from="{yaml}"/>
  </node>
  <node pkg="rtcf" exec="rt_launcher" name="hardware"
        args="tests.ros2.controllers._plants PositionJoints">
    <param name="is_first" value="true"/>
  </node>
  <node pkg="controller_manager" exec="spawner"
        args="joint_state_broadcaster forward_position_controller"/>
  <node pkg="controller_manager" exec="spawner" args="arm_teleop --inactive"/>
</launch>
"""


def test_a_switch_moves_the_claim_of_a_command_topic(ros_node, tmp_path) -> None:
    env, joint_states = _env_and_joint_states(ros_node)
    forward = ros_node.create_publisher(
        Float64MultiArray, "/forward_position_controller/commands", 10)
    teleop = ros_node.create_publisher(Float64MultiArray, "/arm_teleop/commands", 10)
    (tmp_path / "claims.yaml").write_text(CLAIMS_YAML)
    launch = tmp_path / "claims.launch.xml"
    launch.write_text(CLAIMS.format(yaml=tmp_path / "claims.yaml"))
    proc = _proc.start_rtcf(env, "launch", launch, "--middleware", "ros2")

    def claims() -> dict[str, tuple[str, list[str]]]:
        res = call(ros_node, ListControllers, "/controller_manager/list_controllers",
                   ListControllers.Request())
        return {c.name: (c.state, list(c.claimed_interfaces)) for c in res.controller
                if c.name in ("forward_position_controller", "arm_teleop")}

    def follows(command: list[float], publisher) -> bool:
        # the other publishes too: only the active controller's command reaches the arm
        other = teleop if publisher is forward else forward
        return spin_until(ros_node, lambda: bool(joint_states) and list(
            joint_states[-1].position) == command, publish=lambda: (
            publisher.publish(Float64MultiArray(data=command)),
            other.publish(Float64MultiArray(data=[9.0, 9.0, 9.0]))))

    try:
        wait_running(proc, text="real-time:")
        assert claims() == {"forward_position_controller": ("active", ["/position_command"]),
                            "arm_teleop": ("inactive", [])}
        assert follows([0.1, 0.2, 0.3], forward), "the arm did not follow the forward controller"
        # activating the other while the forward controller holds the topic: refused
        assert _switch(ros_node, activate=["arm_teleop"], strictness=BEST_EFFORT) == (
            False, "Unable to activate controller 'arm_teleop' since the command interface "
            "'/position_command' is currently claimed by another controller "
            "('forward_position_controller').")
        # one switch moves the claim
        assert _switch(ros_node, activate=["arm_teleop"],
                       deactivate=["forward_position_controller"]) == (True, "")
        assert claims() == {"forward_position_controller": ("inactive", []),
                            "arm_teleop": ("active", ["/position_command"])}
        joint_states.clear()
        assert follows([0.5, -0.5, 0.25], teleop), "the arm did not follow arm_teleop"
        assert all(list(m.position) != [9.0, 9.0, 9.0] for m in joint_states)
    finally:
        _, err = stop(proc)
    assert "lifecycle: activate: inactive -> active" in err
