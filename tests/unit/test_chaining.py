"""Chained controllers in the core (rtcf._core._chaining, ros2_control's chainable
controllers): reference interfaces in the resource manager's key space, claimed by a
preceding controller; the chain's order from the graph; chained mode; ros2_control's
activation and deactivation rules; no allocation; in-process on a SimClock."""

from __future__ import annotations

import tracemalloc
from typing import Any

import numpy as np
import pytest

import rtcf
from rtcf._core._clock import SimClock
from rtcf._core._faults import FailurePolicy
from rtcf._core._runner import ComponentSpec, Runner
from rtcf._core._settings import RunnerSettings

WHEELS = ("left_wheel_joint", "right_wheel_joint")
URDF = """<?xml version="1.0"?>
<robot name="diffbot">
  <link name="base"/><link name="left"/><link name="right"/>
  <joint name="left_wheel_joint" type="continuous">
    <parent link="base"/><child link="left"/></joint>
  <joint name="right_wheel_joint" type="continuous">
    <parent link="base"/><child link="right"/></joint>
  <ros2_control name="diffbot" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="left_wheel_joint"><command_interface name="velocity"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
    <joint name="right_wheel_joint"><command_interface name="velocity"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
  </ros2_control>
</robot>
"""


class Wheel(rtcf.ChainableComponent):
    """A chainable velocity controller of one wheel (``~wheel``): its reference
    ``<name>/<wheel>/velocity`` from a preceding controller (chained) or from its
    ``~reference`` topic; its command is the reference, to ``<wheel>/velocity``."""

    def configure(self) -> None:
        self.wheel = self.params.get("~wheel", "left_wheel_joint")
        self.references = self.add_reference_interfaces([f"{self.wheel}/velocity"])
        self.topic = self.add_input("~reference", float)
        self.command = self.add_command_interfaces("velocity_command", [f"{self.wheel}/velocity"])
        self.out = np.zeros(1)
        self.seen: list[tuple[int, bool, float]] = []
        self.recording = True  # what it saw, for the tests (off where allocation is measured)
        self.hooks: list[str] = []

    def start(self) -> None:
        self.hooks.append("start")
        self.references[:] = np.nan

    def stop(self) -> None:
        self.hooks.append("stop")

    def on_set_chained_mode(self, chained_mode: bool) -> bool:
        self.hooks.append(f"chained={chained_mode}")
        return True

    def update(self) -> None:
        if not self.in_chained_mode and self.topic.has_new_data:
            self.references[0] = self.topic.read()  # ros2_control: from the subscribers
        if self.recording:
            self.seen.append((self.iteration, self.in_chained_mode, float(self.references[0])))
        if self.references[0] == self.references[0]:
            self.out[0] = self.references[0]
            self.command.write(self.out)


class Base(rtcf.Component):
    """Commands both wheels' references: ``~speed`` plus the iteration."""

    def configure(self) -> None:
        prefixes = self.params.get("~wheels", ["wheel_left", "wheel_right"])
        keys = [f"{p}/{w}/velocity" for p, w in zip(prefixes, WHEELS, strict=False)]
        self.command = self.add_command_interfaces("velocity_command", keys)
        self.speed = self.params.get("~speed", 1.0)
        self.values = np.zeros(len(keys))

    def update(self) -> None:
        self.values[:] = self.speed + self.iteration
        self.command.write(self.values)


class Teleop(rtcf.Component):
    """Writes 5.0 to the left wheel's ``~reference`` topic every iteration."""

    def configure(self) -> None:
        self.out = self.add_output("/wheel_left/reference", float)

    def update(self) -> None:
        self.out.write(5.0)


def runner(**options: Any) -> Runner:
    return Runner(RunnerSettings(frequency=100.0, robot_description=URDF), clock=SimClock(),
                  **options)


def velocity(r: Runner, wheel: str) -> float:
    rm = r.hardware.rm  # type: ignore[union-attr]
    return float(rm.states[rm.state_index[f"{wheel}/velocity"]])


def chain(*, base_autostart: bool = True, wheels_autostart: bool = True) -> Runner:
    r = runner()
    # names chosen so that without the references' edges Kahn would run the wheels first
    r.load(ComponentSpec("wheel_left", cls=Wheel, autostart=wheels_autostart))
    r.load(ComponentSpec("wheel_right", cls=Wheel, params={"wheel": "right_wheel_joint"},
                         autostart=wheels_autostart))
    r.load(ComponentSpec("z_base", cls=Base, autostart=base_autostart))
    return r


def test_the_preceding_controller_runs_first_and_the_chained_one_reads_this_iterations_value(
) -> None:
    r = chain()
    assert r.schedule == ["@hardware.read", "/z_base", "/wheel_left", "/wheel_right",
                          "@hardware.write"]
    edges = {(e.producer.component, e.consumer.component, e.topic) for e in r.graph.edges}
    assert ("/z_base", "/wheel_left", "@reference/wheel_left/left_wheel_joint/velocity") in edges
    r.run(3)
    left = r.components["/wheel_left"]
    assert left.seen == [(0, True, 1.0), (1, True, 2.0), (2, True, 3.0)]
    # the command went on to the hardware, which mirrors it at its next read
    assert list(r.hardware.rm.commands) == [3.0, 3.0]
    assert velocity(r, "left_wheel_joint") == velocity(r, "right_wheel_joint") == 2.0
    # started together: chained before its start, not restarted
    assert left.hooks == ["chained=True", "start"]
    assert r.hardware.claimed_interfaces("/z_base") == [
        "wheel_left/left_wheel_joint/velocity", "wheel_right/right_wheel_joint/velocity"]


def test_chained_mode_follows_the_preceding_controllers_activation() -> None:
    r = chain(base_autostart=False)
    r.load(ComponentSpec("teleop", cls=Teleop))
    r.run(2)
    left = r.components["/wheel_left"]
    assert left.seen[-1] == (1, False, 5.0)  # its topic, not chained
    assert left.hooks == ["start"]
    assert r.change_state("/z_base", "activate").ok
    assert left.hooks == ["start", "stop", "chained=True", "start"]  # restarted, as ros2_control
    r.run(2)
    assert left.seen[-2:] == [(2, True, 3.0), (3, True, 4.0)]  # the topic is ignored
    assert r.change_state("/z_base", "deactivate").ok
    assert left.hooks[-3:] == ["stop", "chained=False", "start"]
    r.run(1)
    assert left.seen[-1] == (4, False, 5.0)  # its topic again


def test_activation_and_deactivation_follow_ros2_controls_rules() -> None:
    r = chain(base_autostart=False, wheels_autostart=False)
    r.run(1)
    outcome = r.change_state("/z_base", "activate")
    assert not outcome.ok and outcome.reason == (
        "The following controller with name 'wheel_left' is currently inactive and it is not "
        "requested to be activated.")
    assert r.change_state("/wheel_left", "activate").ok
    assert r.change_state("/wheel_right", "activate").ok
    assert r.change_state("/z_base", "activate").ok
    outcome = r.change_state("/wheel_left", "deactivate")
    assert not outcome.ok and outcome.reason == (
        "Unable to deactivate controller with name 'wheel_left' because preceding controller "
        "with name 'z_base' is currently active and will not be deactivated.")
    assert r.lifecycle_state("/wheel_left") == "active"
    assert r.change_state("/z_base", "deactivate").ok
    assert r.change_state("/wheel_left", "deactivate").ok
    assert not r.components["/wheel_left"].in_chained_mode


def test_a_reference_claimed_twice_or_missing_is_refused_in_ros2_controls_words() -> None:
    r = chain()
    r.load(ComponentSpec("other", cls=Base, autostart=False))
    r.load(ComponentSpec("typo", cls=Base, params={"wheels": ["wheel_left", "wheel_rihgt"]},
                         autostart=False))
    r.run(1)
    outcome = r.change_state("/other", "activate")
    assert outcome.reason == (
        "Unable to activate controller 'other' since the command interface "
        "'wheel_left/left_wheel_joint/velocity' is currently claimed by another controller. "
        "(by 'z_base')")
    assert r.change_state("/z_base", "deactivate").ok
    outcome = r.change_state("/typo", "activate")
    assert outcome.reason == (
        "Unable to activate controller 'typo' since the command interface "
        "'wheel_rihgt/right_wheel_joint/velocity' is not available. (no hardware component "
        "exports it; did you mean 'wheel_right/right_wheel_joint/velocity'?)")
    assert r.change_state("/other", "activate").ok  # the references are free again


def test_references_are_described_and_the_chain_allocates_nothing() -> None:
    r = chain()
    info = r.describe_component("/wheel_left")
    assert (info["chainable"], info["references"]) == (True, ["left_wheel_joint/velocity"])
    assert r.describe_component("/z_base")["chainable"] is False
    r.run(1)
    for wheel in ("/wheel_left", "/wheel_right"):  # the test's own record kept out
        r.components[wheel].recording = False
    steps = list(r._schedule.compiled().updates)
    for _ in range(20):
        for step in steps:
            step()
    tracemalloc.start()
    # traced from a first 1000 iterations on: what an interpreter makes once when it is
    # traced (3.10 does: frames, caches) is no allocation per iteration
    for _ in range(1000):
        for step in steps:
            step()
    before = tracemalloc.take_snapshot()
    for _ in range(1000):
        for step in steps:
            step()
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename")
                if s.size_diff > 0 and "test_chaining" not in str(s.traceback))
    assert grown < 4096, grown


def test_a_hardware_failure_deactivates_the_preceding_controller_first() -> None:
    r = chain()
    r.run(1)
    said: list[Any] = []
    r.hardware.deactivate = lambda n: said.append(n) or r._transitions.change(n, "deactivate")
    r.hardware._pending.append("diffbot")  # as a failed read leaves it
    r.hardware.feeder()
    assert said[0] == "/z_base" and set(said[1:]) == {"/wheel_left", "/wheel_right"}
    assert [r.lifecycle_state(n) for n in ("/z_base", "/wheel_left")] == ["inactive", "inactive"]


class FailingWheel(Wheel):
    """A wheel whose update raises at iteration 2 (its encoder lost, say)."""

    def update(self) -> None:
        if self.iteration == 2:
            raise RuntimeError("encoder lost")
        super().update()


class CountingBase(Base):
    def update(self) -> None:
        self.ran = [*getattr(self, "ran", []), self.iteration]
        super().update()


def test_a_fault_that_takes_a_chained_controller_out_takes_its_chain_with_it() -> None:
    """on_error: deactivate of a chained controller: the controller that commands its
    references goes out in the same iteration (and what it commands: the other wheel),
    said in one line naming the chain; none is left writing references nobody reads."""
    got: list[str] = []
    r = runner(log_sink=lambda rec: got.append(rec.format()))
    r.load(ComponentSpec("wheel_left", cls=FailingWheel,
                         policy=FailurePolicy(on_error="deactivate")))
    r.load(ComponentSpec("wheel_right", cls=Wheel, params={"wheel": "right_wheel_joint"}))
    r.load(ComponentSpec("z_base", cls=CountingBase))
    r.run(5)
    r.drain_logs()
    assert [r.lifecycle_state(n) for n in ("/z_base", "/wheel_left", "/wheel_right")] == [
        "inactive", "inactive", "inactive"]
    assert r.components["/z_base"].ran == [0, 1, 2]  # not one iteration more
    assert r.hardware.claimed_interfaces("/z_base") == []
    [line] = [t for t in got if "chained: " in t]
    assert line.endswith(
        "chained: /z_base -> /wheel_left; taken out with it: /z_base, /wheel_right (no "
        "controller is left writing reference interfaces nobody reads); activate them again "
        "(switch_controller) once the fault is cleared"), line
    [fault] = r.faults
    assert set(fault.taken_out) == {"/wheel_left", "/z_base", "/wheel_right"}
    # activated again, chained first, it runs again
    for name in ("/wheel_left", "/wheel_right", "/z_base"):
        assert r.change_state(name, "activate").ok, name


@pytest.mark.parametrize("keys", [[], ["velocity"], ["a/velocity", "a/velocity"]])
def test_bad_reference_keys_are_refused_at_configure(keys: list[str]) -> None:
    class Bad(rtcf.ChainableComponent):
        def configure(self) -> None:
            self.add_reference_interfaces(keys)

    with pytest.raises(rtcf.RtcfError, match="reference interfaces"):
        runner().load(ComponentSpec("bad", cls=Bad))


def test_the_chain_is_torn_down_without_a_word() -> None:
    got: list[str] = []
    r = runner(log_sink=lambda rec: got.append(rec.format()))
    for name, wheel in (("wheel_left", WHEELS[0]), ("wheel_right", WHEELS[1])):
        r.load(ComponentSpec(name, cls=Wheel, params={"wheel": wheel}))
    r.load(ComponentSpec("z_base", cls=Base))
    r.run(2)
    r.shutdown()
    r.drain_logs()
    assert not [text for text in got if "claims" in text or "rror" in text], got
