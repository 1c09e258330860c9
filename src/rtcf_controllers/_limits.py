"""Joint limits from a controller's parameters, in ros2_control's joint_limits format.

``joint_limits.<joint>.has_position_limits`` (bool) with ``min_position`` and
``max_position``; ``has_velocity_limits`` with ``max_velocity``; ``has_effort_limits``
with ``max_effort`` (``joint_limits_rosparam.hpp``'s names). A limit counts only where
its ``has_*`` flag is true, as ros2_control reads them. Read once in ``configure``; a
limit that is not finite, a negative maximum or a minimum above the maximum is a
ConfigurationError naming the parameter. Controllers use them to refuse commands
(never to clamp: clamping belongs to the hardware's edge).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from ._params import ControllerParameters


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """Per joint name: ``position`` (min, max); ``velocity`` and ``effort``: the largest
    magnitude. A joint without a limit of that kind is not in the dict."""

    position: dict[str, tuple[float, float]]
    velocity: dict[str, float]
    effort: dict[str, float]

    def outside(self, joint: str, kind: str, value: float) -> str | None:
        """Why ``value`` of ``joint``'s ``kind`` ("position", "velocity", "effort")
        is outside its limits ("4.2, outside its limits [-3.14, 3.14]
        (joint_limits.joint1)"), or None."""
        if kind == "position":
            bounds = self.position.get(joint)
        else:
            largest = (self.velocity if kind == "velocity" else self.effort).get(joint)
            bounds = None if largest is None else (-largest, largest)
        if bounds is None or bounds[0] <= value <= bounds[1]:
            return None
        return (f"{value!r}, outside its limits [{bounds[0]!r}, {bounds[1]!r}] "
                f"(joint_limits.{joint})")


    def position_bounds(self, joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and the highest position of each of ``joints`` (infinite: none)."""
        bounds = [self.position.get(j, (-math.inf, math.inf)) for j in joints]
        return np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])


def _finite(p: ControllerParameters, name: str) -> float:
    value = p.number(name)
    if not math.isfinite(value):
        raise p.error(name, value, "a finite number")
    return value


def read_limits(p: ControllerParameters, joints: Sequence[str]) -> JointLimits:
    """The limits ``joints`` have in the parameters (none: no limits)."""
    position: dict[str, tuple[float, float]] = {}
    velocity: dict[str, float] = {}
    effort: dict[str, float] = {}
    for joint in joints:
        prefix = f"joint_limits.{joint}."
        if p.flag(prefix + "has_position_limits", False):
            low = _finite(p, prefix + "min_position")
            high = _finite(p, prefix + "max_position")
            if low > high:
                raise p.error(prefix + "min_position", low,
                              f"a number <= {prefix}max_position {high!r}")
            position[joint] = (low, high)
        for kind, table in (("velocity", velocity), ("effort", effort)):
            if p.flag(f"{prefix}has_{kind}_limits", False):
                name = f"{prefix}max_{kind}"
                largest = _finite(p, name)
                if largest < 0.0:
                    raise p.error(name, largest, "a number >= 0")
                table[joint] = largest
    return JointLimits(position, velocity, effort)
