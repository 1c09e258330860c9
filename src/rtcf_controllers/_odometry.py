"""diff_drive_controller's odometry: the base's pose in the odometry frame, integrated
from what the wheels did, and its velocity as a rolling mean.

The behaviour of ros2_controllers' Odometry (Jazzy): each update turns the wheels'
travel since the last one into a forward distance and a turn, and integrates them
exactly along the arc (second-order Runge-Kutta when the turn is below 1e-6 rad);
updates less than 0.1 ms apart are skipped. The twist is the mean of the last
``velocity_rolling_window_size`` increments per second. Open loop, the commanded
velocities are integrated instead. Unlike there, the wheels' first position after a
reset is the reference the travel counts from (ros2_controllers counts from zero, so
a wheel not at zero when the controller starts makes a jump).
"""

from __future__ import annotations

import math


class _RollingMean:
    """The mean of the last ``size`` values (fewer until there are that many)."""

    __slots__ = ("_count", "_next", "_sum", "_values")

    def __init__(self, size: int) -> None:
        self._values = [0.0] * max(1, size)
        self.reset()

    def reset(self) -> None:
        self._values[:] = [0.0] * len(self._values)
        self._next = self._count = 0
        self._sum = 0.0

    def add(self, value: float) -> float:
        values, i = self._values, self._next
        self._sum += value - values[i]
        values[i] = value
        self._next = (i + 1) % len(values)
        if self._count < len(values):
            self._count += 1
        return self._sum / self._count


class Odometry:
    """Pose (``x``, ``y``, ``heading``) and velocity (``linear``, ``angular``) of a
    differential-drive base; times in seconds."""

    __slots__ = (
        "_angular_mean", "_left_old", "_left_radius", "_linear_mean", "_right_old",
        "_right_radius", "_separation", "_time", "angular", "heading", "linear", "x", "y",
    )

    def __init__(
        self, separation: float, left_radius: float, right_radius: float, window: int
    ) -> None:
        self._separation = separation
        self._left_radius, self._right_radius = left_radius, right_radius
        self._linear_mean, self._angular_mean = _RollingMean(window), _RollingMean(window)
        self.reset()

    def reset(self) -> None:
        """Back to the origin, at rest; the next update starts the count (its time and,
        with positions, the wheels' positions are the reference)."""
        self.x = self.y = self.heading = 0.0
        self.linear = self.angular = 0.0
        self._time = math.nan
        self._left_old = self._right_old = math.nan
        self._linear_mean.reset()
        self._angular_mean.reset()

    def update(self, left_position: float, right_position: float, time: float) -> bool:
        """From the wheels' angles [rad] (the mean of each side's)."""
        left = left_position * self._left_radius
        right = right_position * self._right_radius
        if math.isnan(self._left_old):
            self._left_old, self._right_old, self._time = left, right, time
            return False
        if time - self._time < 0.0001:
            return False  # too short an interval to estimate a speed over
        left_travel, right_travel = left - self._left_old, right - self._right_old
        self._left_old, self._right_old = left, right
        return self.update_from_travel(left_travel, right_travel, time)

    def update_from_travel(self, left_travel: float, right_travel: float, time: float) -> bool:
        """From the distances the wheels rolled since the last update [m] (velocity
        feedback: each wheel's speed times its radius times the period)."""
        if math.isnan(self._time):
            self._time = time
        dt = time - self._time
        if dt < 0.0001:
            return False
        linear = (left_travel + right_travel) * 0.5
        angular = (right_travel - left_travel) / self._separation
        self._integrate(linear, angular)
        self._time = time
        self.linear = self._linear_mean.add(linear / dt)
        self.angular = self._angular_mean.add(angular / dt)
        return True

    def update_open_loop(self, linear: float, angular: float, time: float) -> None:
        """From the commanded velocities [m/s, rad/s]."""
        if math.isnan(self._time):
            self._time = time
        dt = time - self._time
        self._time = time
        self.linear, self.angular = linear, angular
        self._integrate(linear * dt, angular * dt)

    def _integrate(self, linear: float, angular: float) -> None:
        if abs(angular) < 1e-6:  # Runge-Kutta, second order
            direction = self.heading + angular * 0.5
            self.x += linear * math.cos(direction)
            self.y += linear * math.sin(direction)
            self.heading += angular
        else:  # exactly along the arc
            old = self.heading
            radius = linear / angular
            self.heading += angular
            self.x += radius * (math.sin(self.heading) - math.sin(old))
            self.y -= radius * (math.cos(self.heading) - math.cos(old))
