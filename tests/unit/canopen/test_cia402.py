"""The CiA 402 state machine, stepped without a bus: master and drive side by side."""

from __future__ import annotations

import pytest

pytest.importorskip("canopen")

from rtcf_canopen import _cia402 as c


@pytest.mark.parametrize("state", range(8))
def test_statusword_round_trip(state: int) -> None:
    assert c.state_of(c.STATUSWORD_OF[state] | 0x0200) == state


def _drive_to(target: int, state: int, steps: int = 10) -> list[int]:
    """Master and drive stepped together; the states passed through."""
    cw, seen = 0, [state]
    for _ in range(steps):
        cw = c.step_toward(state, target, cw)
        if state == c.FAULT:
            if cw & c.CW_FAULT_RESET:
                state = c.SWITCH_ON_DISABLED
        else:
            state = c.drive_transition(state, cw)
        seen.append(state)
        if state == target:
            break
    return seen


def test_from_switch_on_disabled_to_operation_enabled() -> None:
    assert _drive_to(c.OPERATION_ENABLED, c.SWITCH_ON_DISABLED) == [
        c.SWITCH_ON_DISABLED, c.READY_TO_SWITCH_ON, c.SWITCHED_ON, c.OPERATION_ENABLED]


def test_a_fault_is_reset_on_the_way_up() -> None:
    assert _drive_to(c.OPERATION_ENABLED, c.FAULT)[:2] == [c.FAULT, c.SWITCH_ON_DISABLED]
    assert _drive_to(c.OPERATION_ENABLED, c.FAULT)[-1] == c.OPERATION_ENABLED


def test_the_fault_reset_is_a_rising_edge() -> None:
    assert c.step_toward(c.FAULT, c.OPERATION_ENABLED, 0) == c.CW_FAULT_RESET
    assert c.step_toward(c.FAULT, c.OPERATION_ENABLED, c.CW_FAULT_RESET) == 0


def test_safe_stop_is_quick_stop_then_voltage_off() -> None:
    assert _drive_to(c.QUICK_STOP_ACTIVE, c.OPERATION_ENABLED) == [
        c.OPERATION_ENABLED, c.QUICK_STOP_ACTIVE]
    assert _drive_to(c.SWITCH_ON_DISABLED, c.QUICK_STOP_ACTIVE) == [
        c.QUICK_STOP_ACTIVE, c.SWITCH_ON_DISABLED]
    # a faulted drive is not reset by a safe stop
    assert c.step_toward(c.FAULT, c.SWITCH_ON_DISABLED) == c.CW_DISABLE_VOLTAGE
    assert c.is_fault(0x0008) and c.is_fault(0x000F) and not c.is_fault(0x0027)


def test_from_quick_stop_back_up_goes_through_switch_on_disabled() -> None:
    assert _drive_to(c.OPERATION_ENABLED, c.QUICK_STOP_ACTIVE)[1] == c.SWITCH_ON_DISABLED
