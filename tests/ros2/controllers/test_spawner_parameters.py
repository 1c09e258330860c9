"""The Jazzy spawner's sequence, driven with rclpy from this process as the real
spawner drives it, against ``rtcf launch --middleware ros2`` and against ``rt_runner``:
``set_parameters`` on the controller manager (``NAME.type``, ``NAME.params_file``,
``NAME.node_options_args``), then ``load_controller``, ``configure_controller`` and
``switch_controller``, while the loop runs a controller the launch file spawned. The
controller gets its type, its parameters from the file's section, and its remap and
``-p`` from the node options; the loop that runs meanwhile pauses only while the load
is served (measured on /joint_states' arrivals, 100 Hz)."""

from __future__ import annotations

import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path

import pytest
from controller_manager_msgs.srv import (
    ConfigureController,
    ListControllers,
    LoadController,
    SwitchController,
    UnloadController,
)
from rcl_interfaces.msg import Parameter
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter as PyParameter
from sensor_msgs.msg import JointState

from ... import _proc
from ..conftest import rtcf_env
from ..test_parameters import call
from ..test_topics import spin_until

pytestmark = pytest.mark.integration

CM = "/controller_manager"
JSB_TYPE = "joint_state_broadcaster/JointStateBroadcaster"
CONTROLLERS = f"""\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: {JSB_TYPE}
    parked:
      type: {JSB_TYPE}
joint_state_broadcaster:
  ros__parameters:
    joints: [shoulder, elbow]
    interfaces: [position]
parked:
  ros__parameters:
    joints: [left, right]
    interfaces: [position]
    use_local_topics: true
"""
# the spawner's -p file: its section is the new controller's (the runner knows nothing
# of it); -p in the node options overrides its frame_id
SPAWNER_FILE = """\
/**:
  ros__parameters:
    unrelated: 1
late:
  ros__parameters:
    joints: [wrist, finger, thumb]
    interfaces: [position]
    frame_id: from_the_file
"""
WHITELIST = "/joint_states|/late_states"


def _ask(node, srv, service: str, **fields):
    return call(node, srv, f"{CM}/{service}", srv.Request(**fields), timeout=30)


def _set_on_manager(node, **values) -> list[bool]:
    """What the spawner's set_controller_parameters sends (one call per parameter)."""
    results = []
    for name, value in values.items():
        request = SetParameters.Request()
        request.parameters = [Parameter(
            name=name, value=PyParameter(name, value=value).get_parameter_value())]
        results += [r.successful for r in
                    call(node, SetParameters, f"{CM}/set_parameters", request, 30).results]
    return results


def _start(kind: str, tmp_path: Path) -> subprocess.Popen[str]:
    yaml = tmp_path / "controllers.yaml"
    yaml.write_text(CONTROLLERS)
    if kind == "rt_runner":
        proc = subprocess.Popen(
            [str(Path(sys.executable).parent / "rt_runner"), "--ros-args", "-r",
             "__node:=rt_runner", "-p", "mode:=no_wait", "-p",
             f"ros_mapping_whitelist:={WHITELIST}", "--params-file", str(yaml)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
            text=True, env=rtcf_env())
        _proc.wait_running(proc, text="ready: 100 Hz")
        return proc
    runner = (f'<node pkg="rtcf" exec="rt_runner" name="rt_runner">'
              f'<param name="ros_mapping_whitelist" value="{WHITELIST}"/>'
              if kind == "rtcf launch" else
              # ros2_control_node read as a runner: its node is the controller manager
              f'<node pkg="controller_manager" exec="ros2_control_node">'
              f'<param name="ros_mapping_whitelist" value="{WHITELIST}"/>')
    launch = tmp_path / "bringup.launch.xml"
    launch.write_text(f"""<launch>
      {runner}<param from="{yaml}"/></node>
      <node pkg="controller_manager" exec="spawner" args="joint_state_broadcaster"/>
      <node pkg="controller_manager" exec="spawner" args="parked --load-only"/>
    </launch>""")
    proc = subprocess.Popen(
        [sys.executable, "-m", "rtcf", "launch", str(launch), "--middleware", "ros2",
         "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
        text=True, env=rtcf_env())
    _proc.wait_running(proc)
    return proc


@pytest.mark.parametrize("kind", ["rtcf launch", "ros2_control_node", "rt_runner"])
def test_the_jazzy_spawners_sequence_loads_while_the_loop_runs(
    ros_node, tmp_path: Path, kind: str
) -> None:
    spawner_file = tmp_path / "late.yaml"
    spawner_file.write_text(SPAWNER_FILE)
    arrivals: list[float] = []
    late: list[JointState] = []
    ros_node.create_subscription(
        JointState, "/joint_states", lambda m: arrivals.append(time.monotonic()), 100)
    ros_node.create_subscription(JointState, "/late_states", late.append, 10)
    proc = _start(kind, tmp_path)
    try:
        if kind == "rt_runner":  # nothing runs yet: the first controller, by the sequence
            assert _ask(ros_node, LoadController, "load_controller",
                        name="joint_state_broadcaster").ok
            assert _ask(ros_node, ConfigureController, "configure_controller",
                        name="joint_state_broadcaster").ok
            assert _ask(ros_node, SwitchController, "switch_controller",
                        activate_controllers=["joint_state_broadcaster"],
                        strictness=SwitchController.Request.STRICT).ok
        assert spin_until(ros_node, lambda: len(arrivals) >= 50, timeout=30), "no /joint_states"

        # the spawner: set_parameters on the manager, then load, configure, activate
        loading = time.monotonic()
        assert _set_on_manager(
            ros_node,
            **{"late.node_options_args": ["--ros-args", "-r", "joint_states:=/late_states",
                                          "-p", "frame_id:=from_the_options"],
               "late.params_file": [str(spawner_file)],
               "late.type": JSB_TYPE}) == [True, True, True]
        assert _ask(ros_node, LoadController, "load_controller", name="late").ok
        loaded = time.monotonic()
        listed = {c.name: (c.state, c.type) for c in
                  _ask(ros_node, ListControllers, "list_controllers").controller}
        assert listed["late"] == ("unconfigured", JSB_TYPE)
        assert listed["joint_state_broadcaster"][0] == "active"
        configuring = time.monotonic()
        assert _ask(ros_node, ConfigureController, "configure_controller", name="late").ok
        configured = time.monotonic()
        assert _ask(ros_node, SwitchController, "switch_controller",
                    activate_controllers=["late"],
                    strictness=SwitchController.Request.STRICT).ok
        assert spin_until(ros_node, lambda: len(late) >= 3, timeout=30), "no /late_states"
        # the params_file's joints; -p's frame_id over the file's
        assert list(late[-1].name) == ["wrist", "finger", "thumb"]
        assert late[-1].header.frame_id == "from_the_options"

        # the loop ran on meanwhile: /joint_states kept arriving, with one pause
        around = [t for t in arrivals if loading - 1.0 <= t <= loaded + 1.0]
        gaps = [b - a for a, b in pairwise(around)]
        pause = max(gaps)
        print(f"{kind}: load_controller took {loaded - loading:.3f} s; the longest gap "
              f"between /joint_states messages around it {pause * 1000:.1f} ms")
        assert pause < 2.0
        # and while its first configure was served (its ports: the graph resolved again)
        pause = max(b - a for a, b in pairwise(arrivals)
                    if b >= configuring and a <= configured)  # the gaps it overlaps
        print(f"{kind}: its first configure_controller took {configured - configuring:.3f} "
              f"s; the longest gap around it {pause * 1000:.1f} ms")
        assert pause < 2.0

        # unloaded once deactivated
        assert _ask(ros_node, SwitchController, "switch_controller",
                    deactivate_controllers=["late"],
                    strictness=SwitchController.Request.STRICT).ok
        assert _ask(ros_node, UnloadController, "unload_controller", name="late").ok
        listed = {c.name: c.state for c in
                  _ask(ros_node, ListControllers, "list_controllers").controller}
        if kind == "rt_runner":
            assert listed == {"joint_state_broadcaster": "active"}
        else:  # the spawner's --load-only: loaded, not configured; configured on request
            assert listed == {"joint_state_broadcaster": "active", "parked": "unconfigured"}
            assert _ask(ros_node, ConfigureController, "configure_controller",
                        name="parked").ok
            listed = {c.name: c.state for c in
                      _ask(ros_node, ListControllers, "list_controllers").controller}
            assert listed["parked"] == "inactive"
    finally:
        proc.send_signal(2)
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
    assert proc.returncode == 0, err[-3000:]
