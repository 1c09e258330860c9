"""Path and goal tolerances of joint_trajectory_controller, and the check against them.

From the parameters (ros2_controllers' ``get_segment_tolerances``): per joint,
``constraints.<joint>.trajectory`` bounds the position error while the trajectory
runs (the path), ``constraints.<joint>.goal`` the position error after its last point
and ``constraints.stopped_velocity_tolerance`` the velocity error there;
``constraints.goal_time`` is how long after the last point's time the joints may take
to get inside the goal tolerance (0: as long as they need). A tolerance of 0 is not
checked. An action goal's ``path_tolerance``, ``goal_tolerance`` and
``goal_time_tolerance`` override them joint by joint as control_msgs/JointTolerance
says: 0 keeps the default, -1 erases it (unchecked), any other negative value is
illegal (the whole goal then runs on the defaults, and the caller logs why). A value
that is not finite is illegal too: ros2_controllers keeps the default for a NaN
without a word; here the goal runs on the defaults and the log says which value.

Tolerances are 3 x joints arrays (rows: position, velocity, acceleration), so that the
check in the loop is a few numpy calls on arrays laid out when a goal arrives.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ._params import ControllerParameters
from ._trajectory import duration_s

ROWS = ("position", "velocity", "acceleration")
_ERASE = -1.0


@dataclasses.dataclass
class Tolerances:
    """``path`` and ``goal``: 3 x joints (0: unchecked); ``goal_time`` [s] (0: none)."""

    path: np.ndarray
    goal: np.ndarray
    goal_time: float

    def copy(self) -> Tolerances:
        return Tolerances(self.path.copy(), self.goal.copy(), self.goal_time)


def from_parameters(params: ControllerParameters, joints: Sequence[str]) -> Tolerances:
    """The defaults the controller's ``constraints`` give."""
    n = len(joints)
    path, goal = np.zeros((3, n)), np.zeros((3, n))
    stopped = params.number("constraints.stopped_velocity_tolerance", 0.01)
    for j, joint in enumerate(joints):
        path[0, j] = params.number(f"constraints.{joint}.trajectory", 0.0)
        goal[0, j] = params.number(f"constraints.{joint}.goal", 0.0)
        goal[1, j] = stopped
    goal_time = params.number("constraints.goal_time", 0.0)
    if goal_time < 0.0:
        raise params.error("constraints.goal_time", goal_time, "a number of seconds >= 0")
    return Tolerances(path, goal, goal_time)


def _resolve(default: float, given: float) -> float:
    if not math.isfinite(given):  # NaN would keep the default, inf disable the check
        raise ValueError(given)
    if given > 0.0:
        return given
    if abs(given - _ERASE) < np.finfo(np.float32).eps:
        return 0.0
    if given < 0.0:
        raise ValueError(given)
    return default


def for_goal(
    defaults: Tolerances, goal: Any, joints: Sequence[str]
) -> tuple[Tolerances, str | None]:
    """The tolerances of a ``FollowJointTrajectory`` goal, and why it runs on the
    defaults instead (an unknown joint, an illegal value) or None."""
    active = defaults.copy()
    duration = goal.goal_time_tolerance
    nanosec = getattr(duration, "nanosec", getattr(duration, "nsecs", 0))
    if not 0 <= nanosec < 1_000_000_000:  # a negative one is _resolve's to judge
        return defaults, f"goal_time_tolerance's nanosec {nanosec} is out of [0, 1e9)"
    goal_time = duration_s(goal.goal_time_tolerance)
    try:
        active.goal_time = _resolve(defaults.goal_time, goal_time)
    except ValueError:
        return defaults, f"goal_time_tolerance {goal_time:g} s is illegal"
    for field, table, fallback in (("path_tolerance", active.path, defaults.path),
                                   ("goal_tolerance", active.goal, defaults.goal)):
        for tolerance in getattr(goal, field):
            if tolerance.name not in joints:
                return defaults, (f"{field} names joint {tolerance.name!r}, not one of "
                                  f"{list(joints)}")
            j = list(joints).index(tolerance.name)
            for row, quantity in enumerate(ROWS):
                value = float(getattr(tolerance, quantity))
                try:
                    table[row, j] = _resolve(fallback[row, j], value)
                except ValueError:
                    why = f"{field} of {tolerance.name!r}: {quantity} {value:g} is illegal"
                    if not math.isfinite(value):
                        why += " (not finite)"
                    return defaults, why
    return active, None


class Checker:
    """The check of errors (3 x joints) against tolerances, in preallocated arrays."""

    def __init__(self, joints: int) -> None:
        self._abs = np.zeros((3, joints))
        self._out = np.zeros((3, joints), dtype=bool)
        self._checked = np.zeros((3, joints), dtype=bool)

    def violation(self, error: np.ndarray, tolerance: np.ndarray) -> int:
        """The first joint whose error is outside a (checked) tolerance, or -1. An
        error that is NaN (a state that is) is outside: an unknown state is not
        within any tolerance."""
        np.abs(error, out=self._abs)
        np.less_equal(self._abs, tolerance, out=self._out)
        np.logical_not(self._out, out=self._out)
        np.greater(tolerance, 0.0, out=self._checked)
        self._out &= self._checked
        if not self._out.any():
            return -1
        return int(self._out.any(axis=0).argmax())  # allocates: once, when it ends a goal

    @staticmethod
    def describe(error: np.ndarray, tolerance: np.ndarray, joint: int, name: str) -> str:
        """Which of the joint's quantities is out, and by how much (for the log)."""
        parts = [
            f"{quantity} error {error[row, joint]:.4g} > {tolerance[row, joint]:.4g}"
            for row, quantity in enumerate(ROWS)
            if tolerance[row, joint] > 0.0 and not abs(error[row, joint]) <= tolerance[row, joint]
        ]
        return f"joint {name}: " + ", ".join(parts)
