"""The resource manager (rtcf._core._resource_manager): hardware loaded by plugin name,
lifecycle rules and initial states as ros2_control's, one buffer per direction with
index arrays, read/write with on_error and DEACTIVATE, claims per joint interface."""

from __future__ import annotations

import math
import tracemalloc
from typing import ClassVar

import numpy as np
import pytest

import rtcf
from rtcf import CallbackReturn, ConfigurationError, ReturnType
from rtcf._core._interface_claims import ClaimError
from rtcf._core._lifecycle import ACTIVE, FINALIZED, INACTIVE, UNCONFIGURED
from rtcf._core._resource_manager import ResourceManager

from .test_generic_system import HEAD, TAIL, hardware, joint

HERE = __name__


class Scripted(rtcf.SystemInterface):
    """A hardware whose answers a test sets (class-wide: the manager builds it)."""

    answers: ClassVar[dict[str, object]] = {}
    calls: ClassVar[list[str]] = []

    def _answer(self, hook: str) -> object:
        Scripted.calls.append(f"{self.name}.{hook}")
        answer = Scripted.answers.get(f"{self.name}.{hook}", Scripted.answers.get(hook))
        if isinstance(answer, Exception):
            raise answer
        return answer

    def on_configure(self, previous_state: rtcf._core._hardware.LifecycleState) -> object:
        return self._answer("on_configure")

    def on_activate(self, previous_state: object) -> object:  # type: ignore[override]
        return self._answer("on_activate")

    def on_deactivate(self, previous_state: object) -> object:  # type: ignore[override]
        return self._answer("on_deactivate")

    def on_cleanup(self, previous_state: object) -> object:  # type: ignore[override]
        return self._answer("on_cleanup")

    def on_error(self, previous_state: object) -> object:  # type: ignore[override]
        return self._answer("on_error")

    def read(self, time: float, period: float) -> object:  # type: ignore[override]
        return self._answer("read")

    def write(self, time: float, period: float) -> object:  # type: ignore[override]
        return self._answer("write")


@pytest.fixture(autouse=True)
def _fresh_script() -> None:
    Scripted.answers = {}
    Scripted.calls = []


def scripted(name: str, body: str, group: str = "") -> str:
    extra = f"<group>{group}</group>" if group else ""
    return (f'<ros2_control name="{name}" type="system"><hardware>'
            f"<plugin>{HERE}:Scripted</plugin>{extra}</hardware>{body}</ros2_control>")


def two_mocks(rate: int = 100) -> ResourceManager:
    """An arm (joint1, joint2) and a gripper (joint3), both GenericSystem."""
    arm = hardware(joint("joint1", ("position", "velocity"), {"position": "1.0",
                                                                "velocity": None})
                   + joint("joint2", ("position",), {"position": "2.0"}), name="arm")
    gripper = hardware(joint("joint3", ("position",), {"position": "3.0"}), name="gripper")
    return ResourceManager.from_urdf(HEAD + arm + gripper + TAIL, rate)


# ------------------------------------------------------------------- the buffers


def test_one_buffer_per_direction_with_every_hardware_as_a_slice() -> None:
    rm = two_mocks()
    assert rm.state_keys == ("joint1/position", "joint2/position", "joint1/velocity",
                             "joint3/position")
    assert rm.command_keys == ("joint1/position", "joint2/position", "joint1/velocity",
                               "joint3/position")
    arm = rm.components["arm"].impl
    gripper = rm.components["gripper"].impl
    assert np.shares_memory(arm.states, rm.states) and np.shares_memory(gripper.states, rm.states)
    assert np.shares_memory(arm.commands, rm.commands)
    idx = rm.command_indices(["joint3/position", "joint1/position"])
    np.put(rm.commands, idx, [0.3, 0.1])  # a controller's scatter
    assert (gripper.get_command("joint3/position"), arm.get_command("joint1/position")) == (
        0.3, 0.1)
    arm.set_state("joint2/position", 2.5)  # the hardware writes, a controller gathers
    out = np.empty(2)
    np.take(rm.states, rm.state_indices(["joint2/position", "joint3/position"]), out=out)
    assert out.tolist() == [2.5, 3.0]
    with pytest.raises(ConfigurationError, match="State interface with key 'joint9/position' "
                                                 "does not exist"):
        rm.state_indices(["joint9/position"])


def test_read_and_write_of_generic_systems_allocate_nothing() -> None:
    rm = two_mocks()
    rm.set_initial_states()
    idx = rm.command_indices(["joint1/position", "joint3/position"])
    values = np.array([0.5, 0.7])
    for _ in range(10):
        rm.read_all(0.0, 0.01)
        rm.write_all(0.0, 0.01)
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    for _ in range(1000):
        np.put(rm.commands, idx, values)
        rm.read_all(0.0, 0.01)
        rm.write_all(0.0, 0.01)
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if s.size_diff > 0)
    assert grown < 4096, grown  # tracemalloc's own bookkeeping, not 1000 iterations' worth
    assert rm.states[rm.state_index["joint3/position"]] == 0.7


# ------------------------------------------------------------------- the lifecycle


def test_hardware_starts_unconfigured_and_initial_states_follow_the_controller_manager() -> None:
    rm = two_mocks()
    assert [c.state.label for c in rm.list_hardware_components()] == ["unconfigured"] * 2
    assert not rm.state_interface_is_available("joint1/position")
    rm.set_initial_states(inactive=["gripper"])
    assert [c.state.label for c in rm.list_hardware_components()] == ["active", "inactive"]
    assert rm.command_interface_is_available("joint3/position")  # configured: available
    rm = two_mocks()
    rm.set_initial_states(unconfigured=["arm"], inactive=["nobody"])
    assert [c.state.id for c in rm.list_hardware_components()] == [UNCONFIGURED, ACTIVE]


def test_set_hardware_component_state_goes_through_the_states_between() -> None:
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    assert rm.set_hardware_component_state("hw", "active") == (True, (ACTIVE, "active"))
    assert Scripted.calls == ["hw.on_configure", "hw.on_activate"]
    Scripted.calls.clear()
    assert rm.set_hardware_component_state("hw", UNCONFIGURED).state.label == "unconfigured"
    assert Scripted.calls == ["hw.on_deactivate", "hw.on_cleanup"]
    assert rm.set_hardware_component_state("nothing", ACTIVE) == (False, (0, ""))
    assert rm.set_hardware_component_state("hw", "finalized").state.id == FINALIZED
    assert rm.set_hardware_component_state("hw", "active") == (False, (FINALIZED, "finalized"))


@pytest.mark.parametrize("answer,state", [
    (CallbackReturn.FAILURE, UNCONFIGURED), (False, UNCONFIGURED),
    (CallbackReturn.ERROR, UNCONFIGURED),  # error processing: on_error succeeds
    (None, INACTIVE), (True, INACTIVE), (CallbackReturn.SUCCESS, INACTIVE),
    (RuntimeError("no bus"), UNCONFIGURED),  # raised: nothing changes
])
def test_configure_results(answer: object, state: int) -> None:
    Scripted.answers["on_configure"] = answer
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    result = rm.set_hardware_component_state("hw", INACTIVE)
    assert result == (state == INACTIVE, (state, rtcf._core._lifecycle.STATE_LABELS[state]))
    assert rm.command_interface_is_available("joint1/position") is (state == INACTIVE)


def test_a_failing_on_error_finalizes() -> None:
    Scripted.answers.update(on_activate=CallbackReturn.ERROR, on_error=CallbackReturn.FAILURE)
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    assert rm.set_hardware_component_state("hw", ACTIVE) == (False, (FINALIZED, "finalized"))


def test_initial_state_failure_is_an_error_naming_the_component() -> None:
    Scripted.answers["on_activate"] = False
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    with pytest.raises(ConfigurationError, match="Failed to set the initial state of the "
                                                 "component : hw to active"):
        rm.set_initial_states()
    rm.set_initial_states(shutdown_on_initial_state_failure=False)  # logged only


def test_a_group_is_rolled_back_to_inactive_when_one_fails_to_activate() -> None:
    Scripted.answers["b.on_activate"] = False
    body = joint("joint1", ("position",), {"position": None})
    rm = ResourceManager.from_urdf(
        HEAD + scripted("a", body, "g") + scripted(
            "b", joint("joint2", ("position",), {"position": None}), "g") + TAIL)
    rm.set_initial_states(shutdown_on_initial_state_failure=False)
    assert [c.state.id for c in rm.list_hardware_components()] == [INACTIVE, INACTIVE]
    assert Scripted.calls == ["a.on_configure", "b.on_configure", "a.on_activate",
                              "b.on_activate", "a.on_deactivate"]


# ------------------------------------------------------------------ read and write


def test_inactive_hardware_is_read_not_written() -> None:
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    rm.read_all(0.0, 0.01)
    rm.write_all(0.0, 0.01)
    assert Scripted.calls == []  # unconfigured: neither
    rm.set_hardware_component_state("hw", INACTIVE)
    Scripted.calls.clear()
    rm.read_all(0.0, 0.01)
    rm.write_all(0.0, 0.01)
    assert Scripted.calls == ["hw.read"]
    rm.set_hardware_component_state("hw", ACTIVE)
    Scripted.calls.clear()
    rm.read_all(0.0, 0.01)
    rm.write_all(0.0, 0.01)
    assert Scripted.calls == ["hw.read", "hw.write"]


@pytest.mark.parametrize("answer", [ReturnType.ERROR, False, ZeroDivisionError("x"),
                                    ReturnType.DEACTIVATE])
def test_a_read_error_goes_through_on_error_and_makes_the_interfaces_unavailable(
        answer: object) -> None:
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    rm.set_initial_states()
    rm.claims.claim("ctrl", ["joint1/position"])
    Scripted.answers["read"] = answer
    status = rm.read_all(0.0, 0.01)
    assert (status.result, status.failed_hardware_names) == (ReturnType.ERROR, ["hw"])
    assert Scripted.calls[-1] == "hw.on_error"
    assert rm.list_hardware_components()[0].state.label == "unconfigured"
    assert not rm.command_interface_is_available("joint1/position")
    assert rm.claims.controllers_using("hw") == ["ctrl"]


@pytest.mark.parametrize("on_error,state", [(CallbackReturn.SUCCESS, "unconfigured"),
                                             (CallbackReturn.FAILURE, "finalized")])
def test_a_failed_read_is_error_processed_once(on_error: object, state: str) -> None:
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    rm.set_initial_states()
    Scripted.answers.update(read=ReturnType.ERROR, on_error=on_error)
    rm.read_all(0.0, 0.01)
    rm.write_all(0.0, 0.01)
    rm.read_all(0.01, 0.01)
    assert Scripted.calls.count("hw.on_error") == 1, Scripted.calls
    assert rm.list_hardware_components()[0].state.label == state


def test_write_deactivate_deactivates_and_error_unconfigures() -> None:
    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})) + TAIL)
    rm.set_initial_states()
    Scripted.answers["write"] = ReturnType.DEACTIVATE
    status = rm.write_all(0.0, 0.01)
    assert (status.result, status.failed_hardware_names) == (ReturnType.DEACTIVATE, ["hw"])
    assert rm.list_hardware_components()[0].state.label == "inactive"
    assert rm.command_interface_is_available("joint1/position")
    rm.set_hardware_component_state("hw", ACTIVE)
    Scripted.answers["write"] = ReturnType.ERROR
    assert rm.write_all(0.0, 0.01).result == ReturnType.ERROR
    assert rm.list_hardware_components()[0].state.label == "unconfigured"


def test_a_slower_rw_rate_reads_at_its_own_rate_with_its_own_period() -> None:
    periods: list[float] = []

    rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
        "position": None})).replace('type="system">', 'type="system" rw_rate="25">') + TAIL, 100)
    rm.set_initial_states()
    rm.components["hw"]._read = lambda time, period: periods.append(period)
    for i in range(12):
        rm.read_all(i * 0.01, 0.01)
    assert len(periods) == 3
    assert periods[1:] == pytest.approx([0.04, 0.04])
    assert rm.list_hardware_components()[0].rw_rate == 25


def test_the_plugin_is_given_the_rate_it_runs_at_as_ros2_control_gives_it() -> None:
    # rw_rate 0 (none) or above the loop's: the loop's rate, in the info on_init sees
    # (a bus plugin plans its load from it at configure); a slower one kept as given
    for attrs, expected in (("", 100), (' rw_rate="250"', 100), (' rw_rate="25"', 25)):
        rm = ResourceManager.from_urdf(HEAD + scripted("hw", joint("joint1", ("position",), {
            "position": None})).replace('type="system">', f'type="system"{attrs}>') + TAIL,
            100)
        assert rm.components["hw"].impl.info.rw_rate == expected, attrs


# ----------------------------------------------------------------------- claims


def test_controllers_on_disjoint_joints_of_one_hardware_run_together() -> None:
    rm = two_mocks()
    rm.set_initial_states()
    claims = rm.claims
    claims.claim("arm_controller", ["joint1/position", "joint2/position"])
    claims.claim("velocity_controller", ["joint1/velocity"])
    claims.claim("gripper_controller", ["joint3/position"])
    _, commands = rm.list_hardware_interfaces()
    assert [(c.name, c.is_claimed) for c in commands] == [
        ("joint1/position", True), ("joint1/velocity", True), ("joint2/position", True),
        ("joint3/position", True)]
    with pytest.raises(ClaimError) as refused:
        claims.claim("other", ["joint3/position"])
    assert str(refused.value) == (
        "Unable to activate controller 'other' since the command interface 'joint3/position' "
        "is currently claimed by another controller. (by 'gripper_controller')")
    # released and claimed in one switch: allowed
    claims.switch({"other": ["joint3/position"]}, ["gripper_controller"])
    assert claims.holder("joint3/position") == "other"
    claims.release("other")
    assert claims.holder("joint3/position") == ""


def test_a_claim_of_what_no_hardware_exports_is_refused_naming_the_likely_one() -> None:
    rm = two_mocks()
    rm.set_initial_states(unconfigured=["gripper"])
    with pytest.raises(ClaimError) as refused:
        rm.claims.claim("forward", ["joint1/positon"])
    assert str(refused.value) == (
        "Unable to activate controller 'forward' since the command interface 'joint1/positon' "
        "is not available. (no hardware component exports it; did you mean 'joint1/position'?)")
    with pytest.raises(ClaimError, match=r"'joint3/position' is not available. \(hardware "
                                         r"component 'gripper' is unconfigured\)"):
        rm.claims.claim("gripper_controller", ["joint3/position"])
    with pytest.raises(ClaimError, match="will be used by another controller that is being "
                                         "activated"):
        rm.claims.switch({"a": ["joint1/position"], "b": ["joint1/position"]})
    with pytest.raises(ClaimError, match="state interface 'joint3/position' is not available"):
        rm.claims.claim("jsb", [], state_keys=["joint3/position"])
    assert rm.claims.claimed_interfaces("a") == ()


def test_claims_on_inactive_hardware_are_refused_by_the_mode_switch() -> None:
    rm = two_mocks()
    rm.set_initial_states(inactive=["gripper"])
    with pytest.raises(ClaimError, match=r"prepare command mode switch was rejected. "
                                         r"\(Component 'gripper' is in INACTIVE state"):
        rm.claims.claim("gripper_controller", ["joint3/position"])
    rm = ResourceManager.from_urdf(
        HEAD + hardware(joint("joint3", ("position",), {"position": None}), name="gripper")
        + TAIL, allow_controller_activation_with_inactive_hardware=True)
    rm.set_initial_states(inactive=["gripper"])
    rm.claims.claim("gripper_controller", ["joint3/position"])


def test_a_hardware_that_refuses_the_mode_switch_leaves_the_claims_unchanged() -> None:
    dyn = hardware(joint("joint1", ("position", "velocity"), {"position": None}),
                   ("calculate_dynamics", "true"))
    rm = ResourceManager.from_urdf(HEAD + dyn + TAIL)
    rm.set_initial_states()
    with pytest.raises(ClaimError, match="Component 'MockHardwareSystem' did not accept"):
        rm.claims.claim("c", ["joint1/position", "joint1/velocity"])
    assert rm.claims.claimed_interfaces("c") == ()
    rm.claims.claim("c", ["joint1/velocity"])
    assert rm.components["MockHardwareSystem"].impl.joint_control_mode == ["velocity"]


# ----------------------------------------------------------------------- loading


def test_loading_errors_are_one_line_naming_the_hardware() -> None:
    body = joint("joint1", ("position",), {"position": None})
    with pytest.raises(ConfigurationError, match="Hardware name hw is duplicated"):
        ResourceManager.from_urdf(HEAD + scripted("hw", body) + scripted("hw", body) + TAIL)
    Scripted.answers["on_init"] = False
    with pytest.raises(ConfigurationError, match="hardware 'x' \\(<plugin>no/Such</plugin>\\)"):
        ResourceManager.from_urdf(HEAD + scripted("x", body).replace(f"{HERE}:Scripted",
                                                                     "no/Such") + TAIL)
    with pytest.raises(ConfigurationError, match="Insert\\[joint1/position\\] \\(hardware 'a' "
                                                 "exports it too\\)"):
        ResourceManager.from_urdf(HEAD + scripted("a", body) + scripted("b", body) + TAIL)


class FailsInit(rtcf.SystemInterface):
    def on_init(self, info: rtcf.HardwareInfo) -> CallbackReturn:
        return CallbackReturn.ERROR

    def read(self, time: float, period: float) -> None:
        pass


class ExportsLess(rtcf.SystemInterface):
    def on_export_state_interfaces(self) -> list:  # type: ignore[type-arg]
        return []

    def read(self, time: float, period: float) -> None:
        pass


def test_a_hardware_that_fails_on_init_or_exports_too_little_is_refused() -> None:
    body = joint("joint1", ("position",), {"position": None})
    tag = scripted("hw", body)
    with pytest.raises(ConfigurationError, match="System hardware component 'hw' from plugin "
                                                 f"'{HERE}:FailsInit' failed to initialize."):
        ResourceManager.from_urdf(HEAD + tag.replace("Scripted", "FailsInit") + TAIL)
    with pytest.raises(ConfigurationError, match=r"Discrepancy between robot description file "
                                                 r".*missing state interfaces: joint1/position"):
        ResourceManager.from_urdf(HEAD + tag.replace("Scripted", "ExportsLess") + TAIL)


def test_shutdown_finalizes_every_hardware() -> None:
    rm = two_mocks()
    rm.set_initial_states()
    assert rm.shutdown_components()
    assert {c.state.id for c in rm.list_hardware_components()} == {FINALIZED}
    assert not rm.state_interface_is_available("joint1/position")
    assert math.isnan(rm.commands[0])
