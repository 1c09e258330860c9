"""The hardware in the loop (rtcf._core._hardware_loop): the schedule's read and write
steps, ports bound to hardware interfaces by key, claims per key at activation, the
description's limits on the commands, a hardware's failure; in-process on a SimClock."""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import rtcf
from rtcf._core._clock import SimClock
from rtcf._core._hardware import ReturnType, SystemInterface
from rtcf._core._ports import FlowStatus
from rtcf._core._runner import ComponentSpec, Runner
from rtcf._core._settings import RunnerSettings

URDF = Path(__file__).parent / "fixtures" / "arm_gripper.urdf"
ARM = [f"joint{i}/position" for i in (1, 2, 3)]


class Arm(rtcf.Component):
    """Moves every arm joint by ``step`` per iteration from where it is."""

    def configure(self) -> None:
        self.position = self.add_state_interfaces("position", ARM)
        self.command = self.add_command_interfaces("position_command", ARM)
        self.step = self.params.get("~step", 0.01)
        self.seen: list[Any] = []

    def update(self) -> None:
        self.seen.append(self.position.status)
        position = self.position.read()
        self.command.write(position + self.step)


class Gripper(rtcf.Component):
    """Commands the gripper's ``~target`` (or the keys of ``~keys``)."""

    def configure(self) -> None:
        keys = self.params.get("~keys", ["gripper_joint/position"])
        self.command = self.add_command_interfaces("position_command", keys)
        self.target = self.params.get("~target", 0.02)

    def update(self) -> None:
        self.command.write(np.full(1, self.target))


def runner(**settings: Any) -> Runner:
    given: dict[str, Any] = {"frequency": 100.0, "robot_description_file": str(URDF)}
    given.update(settings)
    return Runner(RunnerSettings(**given), clock=SimClock())


def state(r: Runner, key: str) -> float:
    rm = r.hardware.rm  # type: ignore[union-attr]
    return float(rm.states[rm.state_index[key]])


def test_the_loop_reads_first_runs_the_controllers_and_writes_last() -> None:
    r = runner()
    r.load(ComponentSpec("gripper", cls=Gripper))
    r.load(ComponentSpec("arm", cls=Arm))
    assert r.schedule == ["@hardware.read", "/arm", "/gripper", "@hardware.write"]
    r.run(10)
    arm = r.components["/arm"]
    # initial 0.1 (joint1) and 0.0: each iteration reads the mirrored command of the last
    assert state(r, "joint1/position") == pytest.approx(0.1 + 0.09)
    assert state(r, "joint3/position") == pytest.approx(0.09)
    assert state(r, "gripper_joint/position") == pytest.approx(0.02)
    assert arm.seen == [FlowStatus.NEW_DATA] * 10  # gathered before every update
    r.shutdown()
    assert [c.state.label for c in r.hardware.rm.list_hardware_components()] == ["finalized"]


def test_bound_ports_are_no_topics_and_without_hardware_they_are() -> None:
    r = runner()
    arm = r.load(ComponentSpec("arm", cls=Arm))
    assert arm.inputs == {} and arm.outputs == {}  # bound: no graph, no middleware
    assert r.describe_component("/arm")["interfaces"] == (ARM, ARM)
    plain = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    arm = plain.load(ComponentSpec("arm", cls=Arm, remaps=[("position_command", "/cmd")]))
    assert set(arm.inputs) == {"position"} and arm.outputs["position_command"].topic == "/cmd"
    assert plain.describe_component("/arm")["claims"] == ["/cmd"]
    assert arm.hardware is None


def test_disjoint_controllers_run_together_and_a_claimed_key_refuses_the_third() -> None:
    r = runner()
    r.load(ComponentSpec("arm", cls=Arm))
    r.load(ComponentSpec("gripper", cls=Gripper))
    r.load(ComponentSpec("other", cls=Gripper, params={"keys": ["joint3/position"]},
                         autostart=False))
    r.run(2)
    assert r.lifecycle_state("/arm") == r.lifecycle_state("/gripper") == "active"
    outcome = r.change_state("/other", "activate")
    assert not outcome.ok
    assert outcome.reason == (
        "Unable to activate controller 'other' since the command interface 'joint3/position' "
        "is currently claimed by another controller. (by 'arm')")
    assert r.change_state("/arm", "deactivate").ok  # releases joint1..3
    assert r.change_state("/other", "activate").ok
    assert r.hardware.claimed_interfaces("/other") == ["joint3/position"]
    r.run(2)
    assert state(r, "joint3/position") == pytest.approx(0.02)


def test_a_key_no_hardware_exports_is_refused_at_activation() -> None:
    r = runner()
    r.load(ComponentSpec("arm", cls=Arm))
    r.load(ComponentSpec("typo", cls=Gripper, params={"keys": ["gripper_joint/positon"]}))
    r.run(1)
    assert r.lifecycle_state("/typo") == "inactive"  # the others run
    assert r.lifecycle_state("/arm") == "active"
    outcome = r.change_state("/typo", "activate")
    assert outcome.reason == (
        "Unable to activate controller 'typo' since the command interface "
        "'gripper_joint/positon' is not available. (no hardware component exports it; did "
        "you mean 'gripper_joint/position'?)")


def test_two_autostarting_claimants_of_one_key_start_the_first_only() -> None:
    r = runner()
    r.load(ComponentSpec("arm", cls=Arm))
    r.load(ComponentSpec("arm2", cls=Arm))
    r.run(1)
    assert [r.lifecycle_state(n) for n in ("/arm", "/arm2")] == ["active", "inactive"]


def test_commands_are_clamped_to_the_descriptions_limits_and_non_finite_ones_held() -> None:
    r = runner()
    r.load(ComponentSpec("gripper", cls=Gripper, params={"target": 0.5}))
    result = r.run(3)
    assert state(r, "gripper_joint/position") == pytest.approx(0.04)  # <limit upper>
    assert result.command_limits["/gripper.position_command"]["clamped"] == {
        "gripper_joint": 3}
    gripper = r.components["/gripper"]
    gripper.target = float("nan")
    result = r.run(3)
    assert state(r, "gripper_joint/position") == pytest.approx(0.04)  # the last one held
    assert result.command_limits["/gripper.position_command"]["refused_not_a_number"] == 3


def test_an_infinite_command_is_the_writers_fault() -> None:
    r = runner()
    r.load(ComponentSpec("gripper", cls=Gripper, params={"target": float("inf")}))
    with pytest.raises(rtcf.ComponentError, match="InfiniteCommand: wrote an infinite "
                                                  "position command to gripper_joint"):
        r.run(3)


class Flaky(SystemInterface):
    """A system whose read fails at its third call."""

    def on_configure(self, previous_state: Any) -> None:
        self.reads = 0

    def read(self, time: float, period: float) -> ReturnType:
        self.reads += 1
        return ReturnType.ERROR if self.reads == 3 else ReturnType.OK

    def write(self, time: float, period: float) -> None:
        return None


FLAKY = f"""<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>
<ros2_control name="flaky" type="system">
  <hardware><plugin>{__name__}:Flaky</plugin></hardware>
  <joint name="j"><command_interface name="velocity"/><state_interface name="velocity"/></joint>
</ros2_control></robot>"""


class Wheel(rtcf.Component):
    def configure(self) -> None:
        self.command = self.add_command_interfaces("velocity_command", ["j/velocity"])

    def update(self) -> None:
        self.command.write(np.ones(1))


def test_a_hardware_that_fails_is_logged_by_name_and_its_controllers_deactivated() -> None:
    got: list[tuple[str, str]] = []
    r = Runner(RunnerSettings(frequency=100.0, robot_description=FLAKY), clock=SimClock(),
               log_sink=lambda rec: got.append((rec.logger, rec.format())))
    r.load(ComponentSpec("wheel", cls=Wheel))
    r.run(5)
    r.drain_logs()
    assert r.lifecycle_state("/wheel") == "inactive"
    assert r.hardware.rm.list_hardware_components()[0].state.label == "unconfigured"
    said = [text for logger, text in got if logger == "/rt_runner/resource_manager"]
    assert any("hardware 'flaky': its read returned ERROR; it is unconfigured now" in s
               for s in said), got


def test_initial_states_and_an_inactive_hardwares_refusal() -> None:
    settings = RunnerSettings.from_params({
        "frequency": 100.0, "robot_description_file": str(URDF),
        "hardware_components_initial_state": {"inactive": ["arm"]}})
    assert settings.hardware_initial_inactive == ("arm",)
    r = Runner(settings, clock=SimClock())
    assert r.hardware.rm.list_hardware_components()[0].state.label == "inactive"
    r.load(ComponentSpec("gripper", cls=Gripper, autostart=False))
    outcome = r.change_state("/gripper", "activate")
    assert "Could not switch controllers since prepare command mode switch was rejected. " \
        "(Component 'arm' is in INACTIVE state" in outcome.reason


def test_a_description_file_that_cannot_be_read_is_one_line() -> None:
    with pytest.raises(rtcf.ConfigurationError, match=r"robot_description_file '/nope.urdf': "
                                                      "cannot read it"):
        runner(robot_description_file="/nope.urdf")


def test_the_bound_steps_allocate_nothing() -> None:
    r = runner()
    r.load(ComponentSpec("arm", cls=Arm, params={"step": 0.0}))
    r.run(1)
    arm = r.components["/arm"]
    command = np.zeros(3)
    arm.update = lambda: arm.command.write(command)  # type: ignore[method-assign]
    r._schedule.invalidate()
    steps = list(r._schedule.compiled().updates)
    for _ in range(20):
        for step in steps:
            step()
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    for _ in range(1000):
        for step in steps:
            step()
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if s.size_diff > 0)
    assert grown < 4096, grown


class Recorded(SystemInterface):
    """A system that records every hook it is given (class-wide: the manager builds it)."""

    calls: list[str] = []  # shared on purpose, reset by the test

    def on_init(self, info: Any) -> None:
        Recorded.calls.append("on_init")

    def on_configure(self, previous_state: Any) -> None:
        Recorded.calls.append("on_configure")

    def on_activate(self, previous_state: Any) -> None:
        Recorded.calls.append("on_activate")

    def read(self, time: float, period: float) -> None:
        Recorded.calls.append("read")

    def write(self, time: float, period: float) -> None:
        Recorded.calls.append("write")


def test_an_offline_runner_touches_no_hardware_and_finds_what_activation_would_refuse(
) -> None:
    """rtcf check's runner: the plugins built to on_init, nothing configured (no bus
    opened); what a start would refuse found from the interfaces that exist."""
    Recorded.calls = []
    r = Runner(RunnerSettings(frequency=100.0, robot_description=FLAKY.replace(
        f"{__name__}:Flaky", f"{__name__}:Recorded")), clock=SimClock(), offline=True)
    try:
        r.load(ComponentSpec("wheel", cls=Wheel))
        r.load(ComponentSpec("typo", cls=Gripper, params={"keys": ["j/velocty"]}))
        r.load(ComponentSpec("second", cls=Wheel))
        assert Recorded.calls == ["on_init"]
        assert r.hardware.rm.list_hardware_components()[0].state.label == "unconfigured"
        assert r.hardware_problems() == [
            "Unable to activate controller 'typo' since the command interface 'j/velocty' "
            "is not available. (no hardware component exports it; did you mean "
            "'j/velocity'?)",
            "Unable to activate controller 'second' since the command interface "
            "'j/velocity' will be used by another controller that is being activated."]
    finally:
        r.shutdown()
    assert "on_activate" not in Recorded.calls
