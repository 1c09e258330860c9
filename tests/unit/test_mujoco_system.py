"""rtcf_examples/MujocoSystem, the examples' hardware plugin, through the resource manager
as the loop drives it (read, a controller's scatter, write), with no ROS: the arm's
description loads it, its joints are the model's, a position command moves a joint and
holds it against gravity, velocity and effort commands drive the joints, a joint the
model lacks is one line, and read and write allocate nothing."""

from __future__ import annotations

import logging
import re
import tracemalloc
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import rtcf
from rtcf._core._hardware_plugins import load_hardware_class
from rtcf._core._resource_manager import ResourceManager
from rtcf._core._robot_description import parse

mujoco = pytest.importorskip("mujoco")

from rtcf_examples import MujocoSystem  # noqa: E402  (after the skip: it needs nothing, its tests mujoco)

EXAMPLES = Path(str(resources.files("rtcf_examples")))
ARM = (EXAMPLES / "description" / "arm.urdf").read_text()
ARM_MODEL = (EXAMPLES / "models" / "arm.xml").read_text()
PERIOD = 0.001
JOINTS = ["joint1", "joint2", "joint3"]


def positions(interface: str = "position") -> list[str]:
    return [f"{j}/{interface}" for j in JOINTS]


def arm(urdf: str = ARM) -> ResourceManager:
    rm = ResourceManager.from_urdf(urdf, update_rate=1000, source="arm.urdf")
    rm.set_initial_states(unconfigured=[], inactive=[])
    return rm


def run(rm: ResourceManager, seconds: float, keys: list[str] | None = None,
        command: np.ndarray | None = None) -> None:
    index = rm.command_indices(keys) if keys else None
    for k in range(round(seconds / PERIOD)):
        rm.read_all(k * PERIOD, PERIOD)
        if index is not None:
            np.put(rm.commands, index, command)
        rm.write_all(k * PERIOD, PERIOD)
    rm.read_all(seconds, PERIOD)


def states(rm: ResourceManager, interface: str = "position") -> np.ndarray:
    return rm.states[rm.state_indices(positions(interface))]


def impl(rm: ResourceManager) -> MujocoSystem:
    system = rm.components["arm"].impl
    assert isinstance(system, MujocoSystem)
    return system


def test_the_arm_description_loads_it_and_maps_its_joints_to_the_models() -> None:
    (info,) = parse(ARM)
    assert info.hardware_plugin_name == "rtcf_examples/MujocoSystem"
    assert load_hardware_class(info) is MujocoSystem
    rm = arm()
    system = impl(rm)
    assert system.path == str(EXAMPLES / "models" / "arm.xml")
    model = system.model
    # each description joint is the model's joint of that name, driven by its motor
    assert [model.joint(int(model.jnt_qposadr.tolist().index(a))).name
            for a in system.qadr] == JOINTS
    assert [model.actuator(int(a)).name for a in system.actuator] == JOINTS
    assert system.kinds == ["motor"] * 3
    assert [h.state.label for h in rm.list_hardware_components()] == ["active"]


def test_a_position_command_moves_the_joints_there_and_holds_them_against_gravity() -> None:
    rm = arm()
    run(rm, 0.5)  # no controller yet (NaN commands): held where it started (initial_value)
    np.testing.assert_allclose(states(rm), [0.0, 0.3, 0.6], atol=1e-3)
    rm.claims.claim("arm_controller", positions())
    target = np.array([0.5, -0.6, 0.8])  # the upper arm and forearm out, under gravity
    run(rm, 2.0, positions(), target)
    np.testing.assert_allclose(states(rm), target, atol=2e-3)  # no sag: gravity compensated
    np.testing.assert_allclose(states(rm, "velocity"), 0.0, atol=1e-3)
    # the effort state is the motors' torque: holding joint2 out takes some
    effort = states(rm, "effort")
    assert abs(effort[1]) > 1.0 and np.all(np.abs(effort) <= 60.0)
    # the controller stops writing: the last target is held
    rm.commands[rm.command_indices(positions())] = np.nan
    run(rm, 0.5)
    np.testing.assert_allclose(states(rm), target, atol=2e-3)


def test_without_gravity_compensation_the_same_pd_sags() -> None:
    rm = arm(ARM.replace('<param name="kd">20</param>', '<param name="kd">20</param>'
                         '<param name="gravity_compensation">false</param>'))
    rm.claims.claim("arm_controller", positions())
    target = np.array([0.5, -0.6, 0.8])
    run(rm, 2.0, positions(), target)
    assert np.abs(states(rm) - target).max() > 0.01


def test_effort_commands_are_the_motors_torques() -> None:
    rm = arm()
    rm.claims.claim("effort_controller", positions("effort"))
    run(rm, 0.2, positions("effort"), np.array([2.0, 3.0, 0.0]))
    position = states(rm)
    assert position[0] > 0.05  # the turntable turned, pushed
    assert position[1] > 0.1  # the shoulder tips over (a PD would hold it within 0.02)
    np.testing.assert_allclose(states(rm, "effort")[:2], [2.0, 3.0])


def test_velocity_commands_through_a_velocity_servo(tmp_path: Path) -> None:
    rm = ResourceManager.from_urdf(DIFFBOT, update_rate=1000)
    rm.set_initial_states(unconfigured=[], inactive=[])
    wheels = ["left_wheel_joint/velocity", "right_wheel_joint/velocity"]
    rm.claims.claim("diffbot_base_controller", wheels)
    system = rm.components["base"].impl
    assert system.kinds == ["velocity servo", "velocity servo"]
    index = rm.command_indices(wheels)
    for k in range(1000):
        rm.read_all(k * PERIOD, PERIOD)
        rm.commands[index] = (4.0, 6.0)
        rm.write_all(k * PERIOD, PERIOD)
    rm.read_all(1.0, PERIOD)
    velocity = rm.states[rm.state_indices(wheels)]
    np.testing.assert_allclose(velocity, (4.0, 6.0), rtol=0.05)
    position = rm.states[rm.state_indices([w.replace("velocity", "position") for w in wheels])]
    assert 3.0 < position[0] < 4.0 and 5.0 < position[1] < 6.0  # integrated by MuJoCo


def test_initial_values_and_the_period_in_timesteps() -> None:
    rm = arm(ARM.replace('<param name="initial_value">0.0</param>',  # joint1's
                         '<param name="initial_value">0.25</param>'))
    system = impl(rm)
    assert system.data.qpos[system.qadr].tolist() == [0.25, 0.3, 0.6]
    np.testing.assert_allclose(states(rm), [0.25, 0.3, 0.6])
    rm.write_all(0.0, 0.0025)  # 2.5 timesteps: 2 now, the half carried to the next
    assert system.data.time == pytest.approx(0.002)
    rm.write_all(0.0025, 0.0025)
    assert system.data.time == pytest.approx(0.005)


def _with_model(tmp_path: Path, model: str) -> str:
    path = tmp_path / "arm.xml"
    path.write_text(model)
    return ARM.replace("rtcf_examples/models/arm.xml", str(path))


def test_a_joint_the_model_lacks_is_one_line(tmp_path: Path, caplog) -> None:
    urdf = _with_model(tmp_path, ARM_MODEL.replace('"joint3"', '"elbow"'))
    expected = (f"hardware 'arm' (<plugin>rtcf_examples/MujocoSystem</plugin>): joint 'joint3' "
                f"is not in the model {tmp_path / 'arm.xml'} (its joints: joint1, joint2, "
                "elbow); name the <joint> as the model's")
    (info,) = parse(urdf)
    with pytest.raises(rtcf.ConfigurationError) as raised:
        MujocoSystem().init(info)
    assert str(raised.value) == expected
    # through the resource manager: the hardware fails to initialize, one line saying why
    with caplog.at_level(logging.ERROR), pytest.raises(rtcf.ConfigurationError) as failed:
        ResourceManager.from_urdf(urdf)
    assert str(failed.value) == ("System hardware component 'arm' from plugin "
                                 "'rtcf_examples/MujocoSystem' failed to initialize. "
                                 f"ConfigurationError: {expected}")
    assert any(expected in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(("change", "message"), [
    (("rtcf_examples/models/arm.xml", "rtcf_examples/models/nope.xml"),
     "model 'rtcf_examples/models/nope.xml': no such file"),
    (("rtcf_examples/models/arm.xml", "no_such_package/arm.xml"),
     "model 'no_such_package/arm.xml': no Python package 'no_such_package'"),
    (('<param name="model">rtcf_examples/models/arm.xml</param>', ""),
     'no <param name="model"> in <hardware>'),
    (('<param name="kp">200</param>', '<param name="kp">stiff</param>'),
     '<param name="kp"> is \'stiff\': give a number'),
])
def test_the_hardwares_parameters_are_checked(change: tuple[str, str], message: str) -> None:
    (info,) = parse(ARM.replace(*change))
    with pytest.raises(rtcf.ConfigurationError, match="^hardware 'arm' .*" + _re(message)):
        MujocoSystem().init(info)


def test_a_command_the_actuator_cannot_take_is_refused(tmp_path: Path) -> None:
    servo = ARM_MODEL.replace('<motor name="joint3" joint="joint3"/>',
                              '<position name="joint3" joint="joint3" kp="100"/>')
    (info,) = parse(_with_model(tmp_path, servo))
    with pytest.raises(rtcf.ConfigurationError, match=_re(
            "joint 'joint3' has a effort command interface, but its actuator 'joint3' in "
            f"{tmp_path / 'arm.xml'} is a position servo, which takes position and velocity "
            "commands")):
        MujocoSystem().init(info)


def test_a_mode_the_actuator_cannot_take_is_refused_at_the_switch(tmp_path: Path,
                                                                   caplog) -> None:
    from rtcf._core._interface_claims import ClaimError

    servo = ARM_MODEL.replace('<motor name="joint3" joint="joint3"/>',
                              '<position name="joint3" joint="joint3" kp="100" kv="10"/>')
    urdf = _with_model(tmp_path, servo)
    effort = urdf.rindex('<command_interface name="effort">')  # joint3's: a servo takes none
    urdf = urdf[:effort] + urdf[urdf.index("</command_interface>", effort) + 21:]
    rm = arm(urdf)
    assert impl(rm).kinds == ["motor", "motor", "position servo"]
    with caplog.at_level(logging.ERROR), pytest.raises(
            ClaimError, match="prepare command mode switch was rejected"):
        rm.claims.claim("velocity_controller", ["joint3/velocity"])
    assert any("joint 'joint3' cannot be commanded by velocity (its position servo "
               "takes: position; position and velocity)" in r.getMessage()
               for r in caplog.records)
    # position (and velocity beside it) is the servo's: it goes there
    rm.claims.claim("arm_controller", positions())
    run(rm, 1.5, positions(), np.array([0.2, 0.5, -0.4]))
    np.testing.assert_allclose(states(rm), [0.2, 0.5, -0.4], atol=0.05)


def test_read_and_write_allocate_nothing() -> None:
    rm = arm()
    rm.claims.claim("arm_controller", [*positions(), *positions("velocity")])
    index = rm.command_indices([*positions(), *positions("velocity")])
    command = np.array([0.2, -0.2, 0.3, 0.0, 0.0, 0.0])
    system = impl(rm)

    def iterations(n: int) -> None:
        for k in range(n):
            system.read(k * PERIOD, PERIOD)
            np.put(rm.commands, index, command)
            system.write(k * PERIOD, PERIOD)

    iterations(50)
    tracemalloc.start()
    try:
        before = tracemalloc.take_snapshot()
        iterations(1000)
        after = tracemalloc.take_snapshot()
        peaks = {call: max(_peak(call) for _ in range(20))
                 for call in (lambda: None, lambda: system.read(0.0, PERIOD),
                              lambda: system.write(0.0, PERIOD))}
    finally:
        tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if s.size_diff > 0)
    assert grown < 1024, grown  # nothing kept
    # made for a moment: the arithmetic's Python floats (whether tracemalloc sees them
    # depends on the float free list's state: up to ~700 B after other tests), never an
    # ndarray per joint (136 B each with three values, more with numpy's temporaries)
    nothing, read, write = peaks.values()
    assert read - nothing < 1024 and write - nothing < 1024, (nothing, read, write)


def _peak(call) -> int:
    now, _ = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    call()
    return tracemalloc.get_traced_memory()[1] - now


def _re(text: str) -> str:
    return re.escape(text)


DIFFBOT = """<?xml version="1.0"?>
<robot name="base">
  <link name="base_link"/><link name="left_wheel"/><link name="right_wheel"/>
  <joint name="left_wheel_joint" type="continuous"><parent link="base_link"/>
    <child link="left_wheel"/><axis xyz="0 1 0"/></joint>
  <joint name="right_wheel_joint" type="continuous"><parent link="base_link"/>
    <child link="right_wheel"/><axis xyz="0 1 0"/></joint>
  <ros2_control name="base" type="system">
    <hardware><plugin>rtcf_examples/MujocoSystem</plugin>
      <param name="model">rtcf_examples/models/diffbot.xml</param></hardware>
    <joint name="left_wheel_joint"><command_interface name="velocity"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
    <joint name="right_wheel_joint"><command_interface name="velocity"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
  </ros2_control>
</robot>
"""
