"""rtcf_controllers._tolerances: constraints from the parameters, a goal's overrides,
and the check."""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

import rtcf
from rtcf.testing import run_components
from rtcf_controllers._params import ControllerParameters
from rtcf_controllers._tolerances import Checker, Tolerances, for_goal, from_parameters

JOINTS = ["a", "b"]


class Reads(rtcf.Component):
    def configure(self) -> None:
        self.tolerances = from_parameters(ControllerParameters(self), JOINTS)


def _from(params: dict) -> Tolerances:
    trace = run_components([rtcf.ComponentSpec("jtc", Reads, params=params)], 1)
    return trace.components["/jtc"].tolerances  # type: ignore[attr-defined]


def test_parameters_give_path_and_goal_tolerances_per_joint() -> None:
    tol = _from({"constraints": {"goal_time": 0.5, "stopped_velocity_tolerance": 0.02,
                                 "a": {"trajectory": 0.1, "goal": 0.01}}})
    assert tol.path.tolist() == [[0.1, 0.0], [0.0, 0.0], [0.0, 0.0]]
    assert tol.goal.tolist() == [[0.01, 0.0], [0.02, 0.02], [0.0, 0.0]]
    assert tol.goal_time == 0.5


def test_defaults_are_ros2_controllers() -> None:
    tol = _from({})
    assert not tol.path.any() and tol.goal[1].tolist() == [0.01, 0.01] and tol.goal_time == 0.0


def test_a_negative_goal_time_is_refused_naming_it() -> None:
    with pytest.raises(rtcf.ComponentError, match=r"constraints\.goal_time"):
        _from({"constraints": {"goal_time": -1.0}})


def _tolerance(name: str, position: float = 0.0, velocity: float = 0.0) -> NS:
    return NS(name=name, position=position, velocity=velocity, acceleration=0.0)


def _goal(path=(), goal=(), goal_time: float = 0.0) -> NS:
    return NS(path_tolerance=list(path), goal_tolerance=list(goal),
              goal_time_tolerance=NS(sec=int(goal_time), nanosec=round(goal_time % 1 * 1e9)))


DEFAULTS = Tolerances(np.array([[0.1, 0.2], [0, 0], [0, 0]], float),
                      np.array([[0.01, 0.02], [0.5, 0.5], [0, 0]], float), 1.0)


def test_a_goal_overrides_keeps_with_zero_and_erases_with_minus_one() -> None:
    tol, why = for_goal(DEFAULTS, _goal([_tolerance("b", 0.3, 0.4)],
                                        [_tolerance("a", -1.0, 0.0)], 2.5), JOINTS)
    assert why is None
    assert tol.path[:2].tolist() == [[0.1, 0.3], [0.0, 0.4]]
    assert tol.goal[:2].tolist() == [[0.0, 0.02], [0.5, 0.5]]
    assert tol.goal_time == 2.5
    assert DEFAULTS.path[0, 1] == 0.2  # the defaults stay as they were


@pytest.mark.parametrize(("goal", "why"), [
    (_goal([_tolerance("x", 1.0)]), "'x'"),
    (_goal(goal=[_tolerance("a", -2.0)]), "position -2 is illegal"),
    # not finite: NaN would keep the default unsaid, inf switch the check off
    (_goal([_tolerance("a", float("nan"))]),
     "path_tolerance of 'a': position nan is illegal (not finite)"),
    (_goal(goal=[_tolerance("b", 0.1, float("inf"))]),
     "goal_tolerance of 'b': velocity inf is illegal (not finite)"),
    (NS(path_tolerance=[], goal_tolerance=[],
        goal_time_tolerance=NS(sec=1, nanosec=2_000_000_000)),
     "goal_time_tolerance's nanosec 2000000000 is out of [0, 1e9)"),
])
def test_a_goal_with_a_bad_tolerance_runs_on_the_defaults(goal: NS, why: str) -> None:
    tol, problem = for_goal(DEFAULTS, goal, JOINTS)
    assert tol is DEFAULTS and problem is not None and why in problem


def test_the_checker_finds_the_first_joint_out_of_a_checked_tolerance() -> None:
    checker = Checker(2)
    tolerance = np.array([[0.1, 0.0], [0.0, 0.5], [0.0, 0.0]])
    assert checker.violation(np.array([[0.05, 9.0], [9.0, 0.4], [9.0, 9.0]]), tolerance) == -1
    error = np.array([[0.05, 0.0], [0.0, -0.6], [0.0, 0.0]])
    assert checker.violation(error, tolerance) == 1
    assert "velocity error -0.6 > 0.5" in Checker.describe(error, tolerance, 1, "b")


def test_an_error_that_is_nan_is_outside_a_checked_tolerance_only() -> None:
    checker = Checker(2)
    tolerance = np.array([[0.0, 0.1], [0.0, 0.0], [0.0, 0.0]])
    nan = float("nan")
    assert checker.violation(np.array([[nan, 0.0], [0.0, 0.0], [0.0, 0.0]]), tolerance) == -1
    error = np.array([[0.0, nan], [0.0, 0.0], [0.0, 0.0]])
    assert checker.violation(error, tolerance) == 1  # an unknown state is not within it
    assert Checker.describe(error, tolerance, 1, "b") == "joint b: position error nan > 0.1"
