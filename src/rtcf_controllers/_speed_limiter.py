"""diff_drive_controller's limits on one velocity: value, acceleration, jerk.

The behaviour of ros2_controllers' SpeedLimiter (Jazzy), which is control_toolbox's
RateLimiter: a limit that is NaN is off; an unset minimum is minus its maximum; the
acceleration bounds depend on the direction the velocity had (forward: from
``max_deceleration`` to ``max_acceleration``; reverse: from
``max_acceleration_reverse`` to ``max_deceleration_reverse``); jerk is limited only
while the speed changes faster than before, in the same direction (so that it cannot
make the closed loop oscillate). Jerk, then acceleration, then value, as there.
"""

from __future__ import annotations

import math

import rtcf

from ._params import ControllerParameters

_NAN = math.nan


def _bounds(low: float, high: float, low_name: str, high_name: str) -> tuple[bool, float, float]:
    """A pair of limits: on unless ``high`` is NaN; an unset ``low`` is ``-high``."""
    if math.isnan(low):
        low = -high
    on = not math.isnan(high)
    if on and low > high:
        raise ValueError(f"{low_name} {low} > {high_name} {high}")
    return on, low, high


class SpeedLimiter:
    """Limits for one velocity (``linear.x`` or ``angular.z``), checked when made."""

    __slots__ = (
        "_acceleration", "_fwd", "_jerk", "_max_jerk", "_max_value", "_min_jerk", "_min_value",
        "_rev", "_value", "_zero",
    )

    def __init__(
        self,
        min_velocity: float = _NAN,
        max_velocity: float = _NAN,
        max_acceleration_reverse: float = _NAN,
        max_acceleration: float = _NAN,
        max_deceleration: float = _NAN,
        max_deceleration_reverse: float = _NAN,
        min_jerk: float = _NAN,
        max_jerk: float = _NAN,
    ) -> None:
        nan = math.isnan
        self._value, self._min_value, self._max_value = _bounds(
            min_velocity, max_velocity, "min_velocity", "max_velocity"
        )
        self._acceleration, max_acceleration_reverse, max_acceleration = _bounds(
            max_acceleration_reverse, max_acceleration, "max_acceleration_reverse",
            "max_acceleration",
        )
        if self._acceleration:
            if nan(max_deceleration_reverse):
                max_deceleration_reverse = max_acceleration
            if nan(max_deceleration):
                max_deceleration = max_acceleration_reverse
            if max_deceleration > max_deceleration_reverse:
                raise ValueError(
                    f"max_deceleration {max_deceleration} > "
                    f"max_deceleration_reverse {max_deceleration_reverse}"
                )
        # the bounds of a change per second when moving forward, reverse, or standing
        self._fwd = (max_deceleration, max_acceleration)
        self._rev = (max_acceleration_reverse, max_deceleration_reverse)
        self._zero = (max_acceleration_reverse, max_acceleration)
        self._jerk, self._min_jerk, self._max_jerk = _bounds(
            min_jerk, max_jerk, "min_jerk", "max_jerk"
        )

    def limit(self, v: float, v0: float, v1: float, dt: float) -> float:
        """``v`` limited, given the two velocities before it (``v0`` the last, ``v1``
        the one before) and the time step ``dt`` [s]."""
        if self._jerk:
            dv, dv0 = v - v0, v0 - v1
            if (dv - dv0) * dv > 0.0:  # accelerating more, in the direction it moves
                dt2 = dt * dt
                v = v0 + dv0 + min(max(dv - dv0, self._min_jerk * dt2), self._max_jerk * dt2)
        if self._acceleration:
            low, high = self._fwd if v0 > 0.0 else self._rev if v0 < 0.0 else self._zero
            v = v0 + min(max(v - v0, low * dt), high * dt)
        if self._value:
            v = min(max(v, self._min_value), self._max_value)
        return v


def speed_limiter(
    params: ControllerParameters, component: rtcf.Component, axis: str
) -> SpeedLimiter:
    """The limiter of ``axis`` (``linear.x``, ``angular.z``) from the controller's
    parameters: ``<axis>.max_velocity`` and the rest, NaN (unlimited) by default, each
    checked for its sign; the deprecated ``has_*_limits: false`` switch a group off."""

    def number(name: str, sign: float) -> float:
        value = params.number(f"{axis}.{name}", _NAN, nan=True)
        if value * sign < 0.0:
            raise rtcf.ConfigurationError(
                f"component {component.full_name!r}: parameter {axis}.{name} is {value}; "
                f"give a number {'>=' if sign > 0 else '<='} 0, or .NAN for no limit"
            )
        return value

    limits = {
        "min_velocity": number("min_velocity", -1.0),
        "max_velocity": number("max_velocity", 1.0),
        "max_acceleration_reverse": number("max_acceleration_reverse", -1.0),
        "max_acceleration": number("max_acceleration", 1.0),
        "max_deceleration": number("max_deceleration", -1.0),
        "max_deceleration_reverse": number("max_deceleration_reverse", 1.0),
        "min_jerk": number("min_jerk", -1.0),
        "max_jerk": number("max_jerk", 1.0),
    }
    groups = {
        "has_velocity_limits": ("min_velocity", "max_velocity"),
        "has_acceleration_limits": (
            "max_acceleration_reverse", "max_acceleration", "max_deceleration",
            "max_deceleration_reverse",
        ),
        "has_jerk_limits": ("min_jerk", "max_jerk"),
    }
    for flag, names in groups.items():
        if not params.flag(f"{axis}.{flag}", True):
            component.log.warning(
                "%s.%s is deprecated: set the limits to .NAN instead", axis, flag
            )
            for name in names:
                limits[name] = _NAN
    try:
        return SpeedLimiter(**limits)
    except ValueError as exc:
        raise rtcf.ConfigurationError(
            f"component {component.full_name!r}: the {axis} limits are inconsistent: {exc}"
        ) from None
