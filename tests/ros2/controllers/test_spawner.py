"""A ros2_control spawner's sequence against an rt_runner given the team's controllers
YAML (``--params-file``, what ``<param from=...>`` on its node passes): an rclpy client
in this process calls ``/controller_manager/list_controllers``, ``load_controller``,
``configure_controller`` and ``switch_controller`` for a joint_state_broadcaster named
only in the YAML (no rt_launcher for it), and ``/joint_states`` then arrives with the
YAML's joints; an unknown type is refused, and so is the unload of an active controller,
with ros2_control's messages on /rosout. One runner process for the module."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from controller_manager_msgs.srv import (
    ConfigureController,
    ListControllers,
    ListControllerTypes,
    LoadController,
    SwitchController,
    UnloadController,
)
from sensor_msgs.msg import JointState

from ... import _proc
from ..conftest import rtcf_env
from ..test_logging import rosout
from ..test_parameters import call
from ..test_topics import spin_until

pytestmark = pytest.mark.integration

CM = "/controller_manager"
JSB = "joint_state_broadcaster"
JSB_TYPE = "joint_state_broadcaster/JointStateBroadcaster"
CONTROLLERS = f"""\
controller_manager:
  ros__parameters:
    update_rate: 100
    {JSB}:
      type: {JSB_TYPE}
    mystery:
      type: my_controllers/Mystery
{JSB}:
  ros__parameters:
    joints: [shoulder, elbow]
    interfaces: [position]
"""


def _ask(node, srv, service: str, **fields):
    return call(node, srv, f"{CM}/{service}", srv.Request(**fields), timeout=30)


def _listed(node) -> dict[str, tuple[str, str, int]]:
    res = _ask(node, ListControllers, "list_controllers")
    return {c.name: (c.state, c.type, c.update_rate) for c in res.controller}


def _switch(node, activate=(), deactivate=()) -> tuple[bool, str]:
    res = _ask(node, SwitchController, "switch_controller", activate_controllers=list(activate),
               deactivate_controllers=list(deactivate),
               strictness=SwitchController.Request.STRICT)
    return res.ok, res.message


def test_a_spawners_sequence_loads_configures_and_activates_a_controller_by_name(
    ros_node, tmp_path: Path
) -> None:
    yaml = tmp_path / "controllers.yaml"
    yaml.write_text(CONTROLLERS)
    joint_states: list[JointState] = []
    ros_node.create_subscription(JointState, "/joint_states", joint_states.append, 10)
    records = rosout(ros_node)

    def logged(text: str) -> bool:
        return spin_until(ros_node, lambda: any(r.msg == text for r in records))

    # no frequency given: the controller manager's update_rate is the loop's
    proc = subprocess.Popen(
        [str(Path(sys.executable).parent / "rt_runner"), "--ros-args", "-r",
         "__node:=rt_runner", "-p", "mode:=no_wait", "-p",
         "ros_mapping_whitelist:=/joint_states", "--params-file", str(yaml)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
        env=rtcf_env())
    try:
        _proc.wait_running(proc, text="ready: 100 Hz")
        types = _ask(ros_node, ListControllerTypes, "list_controller_types")
        assert JSB_TYPE in types.types and "pid_controller/PidController" in types.types
        assert set(types.base_classes) == {"controller_interface::ControllerInterface"}

        # the spawner: is it loaded? load, configure, activate
        assert JSB not in _listed(ros_node)
        assert _ask(ros_node, LoadController, "load_controller", name=JSB).ok
        assert _listed(ros_node) == {JSB: ("unconfigured", JSB_TYPE, 100)}
        assert _ask(ros_node, ConfigureController, "configure_controller", name=JSB).ok
        assert _listed(ros_node)[JSB][0] == "inactive"
        assert not joint_states  # not started by the loop on its own
        assert _switch(ros_node, activate=[JSB]) == (True, "")
        assert spin_until(ros_node, lambda: len(joint_states) >= 3), "no /joint_states"
        assert list(joint_states[-1].name) == ["shoulder", "elbow"]  # the YAML's joints
        assert _listed(ros_node)[JSB][0] == "active"

        # refusals, answered ok=False and said in ros2_control's words
        assert not _ask(ros_node, LoadController, "load_controller", name="mystery").ok
        assert logged("Loader for controller 'mystery' (type 'my_controllers/Mystery') not "
                      "found."), [r.msg for r in records]
        assert not _ask(ros_node, LoadController, "load_controller", name="nameless").ok
        assert logged("The 'type' param was not defined for 'nameless'.")
        assert not _ask(ros_node, LoadController, "load_controller", name=JSB).ok
        assert logged(f"A controller named '{JSB}' was already loaded inside the controller "
                      "manager")
        assert not _ask(ros_node, UnloadController, "unload_controller", name=JSB).ok
        assert logged(f"Could not unload controller with name '{JSB}' because it is still "
                      "active")
        assert _listed(ros_node)[JSB][0] == "active"

        # deactivated, it unloads
        assert _switch(ros_node, deactivate=[JSB]) == (True, "")
        assert _ask(ros_node, UnloadController, "unload_controller", name=JSB).ok
        assert _listed(ros_node) == {}
    finally:
        _, err = _proc.interrupt(proc)
    assert proc.returncode == 0, err
    assert f"loaded /{JSB} (rtcf_controllers.JointStateBroadcaster)" in err


# a controller of the test's own, installed by an entry point: it notes each
# construction and each configure in the file its parameter ``notes`` names
COUNTING = '''\
from rtcf import Component


class Counting(Component):
    def __init__(self):
        super().__init__()
        self._note("init")

    def _note(self, what):
        with open(self.params.get("~notes"), "a") as f:
            f.write(what + "\\n")

    def configure(self):
        self._note("configure")
        self.out = self.add_output("counted", float)

    def update(self):
        self.out.write(float(self.iteration))
'''


def _install_counting(root: Path) -> None:
    (root / "counting_controller.py").write_text(COUNTING)
    info = root / "counting_controller-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: counting-controller\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[rtcf.controllers]\ncounting/Counting = counting_controller:Counting\n")


def test_load_controller_does_not_configure_and_the_first_configure_wires_its_ports(
    ros_node, tmp_path: Path
) -> None:
    """load_controller constructs the controller only (ros2_control's on_init): its
    configure (a device opened, an ONNX session made) first runs at
    configure_controller, and its ports then reach the loop's plan and ROS. A first
    configure through the controller's own lifecycle service (the loop running) too."""
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState
    from std_msgs.msg import Float64

    _install_counting(tmp_path)
    notes = {name: tmp_path / f"{name}.notes" for name in ("first", "second")}
    yaml = tmp_path / "controllers.yaml"
    yaml.write_text("controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
                    + "".join(f"    {n}:\n      type: counting/Counting\n" for n in notes)
                    + "".join(f"{n}:\n  ros__parameters:\n    notes: {p}\n"
                              for n, p in notes.items()))
    counted: list[float] = []
    ros_node.create_subscription(Float64, "/counted", lambda m: counted.append(m.data), 10)
    env = rtcf_env()
    env["PYTHONPATH"] = f"{tmp_path}:{env.get('PYTHONPATH', '')}"
    proc = subprocess.Popen(
        [str(Path(sys.executable).parent / "rt_runner"), "--ros-args", "-r",
         "__node:=rt_runner", "-p", "mode:=no_wait", "-p",
         "ros_mapping_whitelist:=/counted", "--params-file", str(yaml)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
        env=env)

    def noted(name: str) -> list[str]:
        path = notes[name]
        return path.read_text().split() if path.exists() else []

    try:
        _proc.wait_running(proc, text="ready: 100 Hz")
        assert "counting/Counting" in _ask(ros_node, ListControllerTypes,
                                           "list_controller_types").types
        assert _ask(ros_node, LoadController, "load_controller", name="first").ok
        assert noted("first") == ["init"]  # constructed, not configured
        assert _listed(ros_node)["first"][0] == "unconfigured"
        assert _ask(ros_node, ConfigureController, "configure_controller", name="first").ok
        assert noted("first") == ["init", "configure"]
        assert _listed(ros_node)["first"][0] == "inactive"
        assert _switch(ros_node, activate=["first"]) == (True, "")
        assert spin_until(ros_node, lambda: len(counted) >= 3), "no /counted"

        # the controller's own lifecycle service, while the loop runs
        assert _switch(ros_node, deactivate=["first"]) == (True, "")
        assert _ask(ros_node, UnloadController, "unload_controller", name="first").ok
        assert _ask(ros_node, LoadController, "load_controller", name="second").ok
        assert noted("second") == ["init"]
        counted.clear()
        change = ChangeState.Request(transition=Transition(label="configure"))
        assert call(ros_node, ChangeState, "/second/change_state", change, timeout=30).success
        assert noted("second") == ["init", "configure"]
        assert _switch(ros_node, activate=["second"]) == (True, "")
        assert spin_until(ros_node, lambda: len(counted) >= 3), "no /counted from second"
    finally:
        _, err = _proc.interrupt(proc)
    assert proc.returncode == 0, err
