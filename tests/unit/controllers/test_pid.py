"""rtcf_controllers._pid: control_toolbox's PID (Jazzy), step by step, against numbers
worked out by hand. No ROS: the message side is tests/ros2/controllers/test_simple.py."""

from __future__ import annotations

import math

import pytest

from rtcf_controllers._pid import Gains, Pid, shortest_angular_distance

DT = 0.5


def _commands(pid: Pid, errors: list[float]) -> list[float]:
    # error_dot 0: the d term out of the way, the integral strategies alone
    return [pid.compute_with_rate(e, 0.0, DT) for e in errors]


def test_none_integrates_after_the_command_and_the_output_clamp_holds_it() -> None:
    pid = Pid(Gains(p=1.0, i=1.0, u_clamp_max=1.5, antiwindup_strategy="none"))
    # e 2: p 2 + i 0 = 2 -> 1.5, then i += 0.5 * 1 * 2 = 1; e 2: 2 + 1 = 3 -> 1.5, i 2;
    # e -1: -1 + 2 = 1
    assert _commands(pid, [2.0, 2.0, -1.0]) == [1.5, 1.5, 1.0]
    assert pid.i_term == 1.5


def test_conditional_integration_stops_while_saturated_in_the_error_s_direction() -> None:
    pid = Pid(Gains(p=1.0, i=1.0, u_clamp_max=1.5, antiwindup_strategy="conditional_integration"))
    # saturated (2 -> 1.5) with the error the same sign: no integration; then e -1: -1,
    # not saturated: i += 0.5 * 1 * -1
    assert _commands(pid, [2.0, 2.0, -1.0]) == [1.5, 1.5, -1.0]
    assert pid.i_term == -0.5


def test_back_calculation_bleeds_the_saturation_off_with_its_default_time_constant() -> None:
    pid = Pid(Gains(p=1.0, i=1.0, u_clamp_max=1.5, antiwindup_strategy="back_calculation"))
    pid.gains.tracking_time_constant = 1.0  # what Gains.read makes of 0 with d 0: p / i
    # e 2: 2 -> 1.5; i += 0.5 (1 * 2 + (1.5 - 2) / 1) = 0.75; e 0.5: 0.5 + 0.75 = 1.25
    assert _commands(pid, [2.0, 0.5]) == [1.5, 1.25]
    assert pid.i_term == pytest.approx(0.75 + 0.5 * 0.5)


def test_legacy_stops_integrating_inside_the_deadband_and_clamps_the_integral() -> None:
    pid = Pid(Gains(i=1.0, i_clamp_max=0.6, error_deadband=0.1))
    # e 1: i 0.5; e 0.05 (in the deadband): stays 0.5; e 1: 1.0 -> 0.6
    assert _commands(pid, [1.0, 0.05, 1.0]) == [0.5, 0.5, 0.6]


def test_the_derivative_is_a_backward_difference_from_zero_after_a_reset() -> None:
    pid = Pid(Gains(d=2.0, i=1.0, save_i_term=False))
    assert pid.compute(1.0, DT) == 2.0 * (1.0 - 0.0) / DT + 0.5
    assert pid.compute(1.5, DT) == 2.0 * 0.5 / DT + 0.5 + 0.75
    pid.reset()
    assert (pid.i_term, pid.compute(1.0, DT)) == (0.0, 2.0 * 1.0 / DT + 0.5)


def test_save_i_term_keeps_the_integral_across_a_reset() -> None:
    pid = Pid(Gains(i=1.0))
    pid.compute(1.0, DT)
    pid.reset()
    assert pid.i_term == 0.5  # save_i_term is true by default (pid_controller's YAML)


def test_no_time_step_repeats_the_last_command_and_a_nan_error_gives_nan() -> None:
    pid = Pid(Gains(p=3.0))
    assert pid.compute(1.0, DT) == 3.0
    assert pid.compute(5.0, 0.0) == 3.0
    assert math.isnan(pid.compute(math.nan, DT))
    assert math.isnan(pid.compute_with_rate(1.0, math.inf, DT))


@pytest.mark.parametrize(
    ("gains", "problem"),
    [
        (Gains(i_clamp_min=0.5), ("i_clamp_min", 0.5, "a number <= 0")),
        (Gains(i_clamp_max=-0.5), ("i_clamp_max", -0.5, "a number >= 0")),
        (Gains(u_clamp_min=2.0, u_clamp_max=1.0),
         ("u_clamp_min", 2.0, "a number <= u_clamp_max 1.0")),
        (Gains(), None),
    ],
)
def test_gains_control_toolbox_refuses(gains: Gains, problem: tuple | None) -> None:
    assert gains.problem() == problem


@pytest.mark.parametrize(
    ("start", "end", "distance"),
    [(0.0, 1.5 * math.pi, -0.5 * math.pi), (0.0, math.pi, math.pi),
     (0.0, -math.pi, math.pi), (-3.0, 3.0, 6.0 - 2 * math.pi), (1.0, 0.5, -0.5)],
)
def test_shortest_angular_distance_is_in_minus_pi_to_pi(
    start: float, end: float, distance: float
) -> None:
    assert shortest_angular_distance(start, end) == pytest.approx(distance, abs=1e-12)
