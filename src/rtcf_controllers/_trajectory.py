"""A joint trajectory as joint_trajectory_controller samples it: the splines between points.

A trajectory is n points (each a ``time_from_start`` and, per joint, a position and
optionally a velocity, an acceleration and an effort) plus the state the joints are in
when it starts. Each segment is a polynomial in the time since its first point, its
degree given by the fields both of its ends have, as ros2_controllers'
``Trajectory::interpolate_between_points`` chooses it:

* positions only: linear;
* positions and velocities: cubic (position and velocity at both ends);
* positions, velocities and accelerations: quintic (all three at both ends).

The first segment runs from the state at the start (``begin``) to the first point; a
state without velocities (or accelerations) counts as zero where the first point has
them, so that segment has the degree of the rest. After the last point, the sample is
the last point (missing velocities, accelerations and efforts as zero). Efforts are
interpolated linearly. ``interpolation_method: none`` gives the next point's values.

Everything that allocates happens in :meth:`Trajectory.begin` (a new trajectory: the
coefficients of every segment); :meth:`Trajectory.sample` writes into the caller's
arrays. Messages are read here by duck typing (``trajectory_msgs/JointTrajectory``'s
fields), so this module imports no ROS package.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ._limits import JointLimits

ORDER = 6  # coefficients of a quintic, the highest degree a segment has


def duration_s(duration: Any) -> float:
    """A ``builtin_interfaces/Duration`` (or ROS 1's) in seconds."""
    sec = getattr(duration, "sec", None)
    if sec is None:
        return float(duration.secs) + 1e-9 * float(duration.nsecs)
    return float(sec) + 1e-9 * float(duration.nanosec)


def duration_problem(duration: Any) -> str | None:
    """Why a ``time_from_start`` is no duration a point can have (negative, or its
    nanoseconds out of [0, 1e9)), or None."""
    sec = getattr(duration, "sec", None)
    nsec = duration.nsecs if sec is None else duration.nanosec
    if sec is None:
        sec = duration.secs
    if sec < 0:
        return f"{sec} s {nsec} ns (negative)"
    if not 0 <= nsec < 1_000_000_000:
        return f"{sec} s {nsec} ns (nanoseconds out of [0, 1e9))"
    return None


# a point's fields and what one of their values is called in a refusal
_FIELDS = (("positions", "position"), ("velocities", "velocity"),
           ("accelerations", "acceleration"), ("effort", "effort"))


def _spline(
    p0: np.ndarray, v0: np.ndarray | None, a0: np.ndarray | None,
    p1: np.ndarray, v1: np.ndarray | None, a1: np.ndarray | None, span: float,
) -> np.ndarray:
    """The coefficients (ORDER x joints, lowest power first) of one segment of ``span``
    seconds: linear, cubic or quintic by the derivatives both ends give."""
    c = np.zeros((ORDER, p0.shape[0]))
    c[0] = p0
    if span <= 0.0:
        return c  # a zero-length segment: its start point
    if v0 is None or v1 is None:  # accelerations without velocities count for nothing
        c[1] = (p1 - p0) / span
    elif a0 is None or a1 is None:
        c[1] = v0
        c[2] = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * span) / span**2
        c[3] = (2.0 * (p0 - p1) + (v0 + v1) * span) / span**3
    else:
        c[1] = v0
        c[2] = 0.5 * a0
        c[3] = (20.0 * (p1 - p0) - (12.0 * v0 + 8.0 * v1) * span
                - (3.0 * a0 - a1) * span**2) / (2.0 * span**3)
        c[4] = (30.0 * (p0 - p1) + (16.0 * v0 + 14.0 * v1) * span
                + (3.0 * a0 - 2.0 * a1) * span**2) / (2.0 * span**4)
        c[5] = (12.0 * (p1 - p0) - 6.0 * (v0 + v1) * span
                - (a0 - a1) * span**2) / (2.0 * span**5)
    return c


# d/dt of a polynomial's coefficients, as a matrix: (derivative coefficients) = D @ c
_DERIVE = np.diag(np.arange(1.0, ORDER), k=1)


class Trajectory:
    """Points in the controller's joint order, to be started by :meth:`begin`.

    ``times``: each point's ``time_from_start`` [s], strictly increasing; ``positions``
    (n x joints); ``velocities``, ``accelerations``, ``effort``: n x joints or None
    (the field is absent). ``start``: the time [s, the controller's clock] of
    ``time_from_start`` 0, or None for "when it begins" (a zero header stamp).
    ``interpolate``: False for ``interpolation_method: none``.
    """

    def __init__(
        self,
        times: Sequence[float],
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
        accelerations: np.ndarray | None = None,
        effort: np.ndarray | None = None,
        *,
        start: float | None = None,
        interpolate: bool = True,
    ) -> None:
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        n, dof = self.positions.shape
        self.n, self.dof = n, dof

        def field(values: np.ndarray | None) -> np.ndarray | None:
            return None if values is None else np.asarray(values, dtype=float).reshape(n, dof)

        self.velocities = field(velocities)
        self.accelerations = field(accelerations)
        self.effort = field(effort)
        self.start = start
        self.interpolate = interpolate
        self.begun = False
        self.sampled = False  # whether sample() has advanced since begin()
        self.ends = np.zeros(n)  # each point's time on the controller's clock
        self._cursor = 0

    @property
    def end_time(self) -> float:
        """When the last point is due (after :meth:`begin`)."""
        return float(self.ends[-1])

    def last_point(self) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The last point's positions, velocities and accelerations (None: absent)."""
        v = None if self.velocities is None else self.velocities[-1]
        a = None if self.accelerations is None else self.accelerations[-1]
        return self.positions[-1], v, a

    def begin(
        self,
        now: float,
        position: np.ndarray,
        velocity: np.ndarray | None = None,
        acceleration: np.ndarray | None = None,
    ) -> None:
        """Start at ``now`` from the given state: lays out every segment's coefficients."""
        start = now if self.start is None else self.start
        self.start = start
        self.ends = start + self.times
        self.begun = True
        self.sampled = False
        self._cursor = 0
        # the segment before the first point, from the state at the start
        p, v, a = self.positions, self.velocities, self.accelerations
        zero = np.zeros(self.dof)
        v_now = None if v is None else (zero if velocity is None else velocity)
        a_now = None if a is None else (zero if acceleration is None else acceleration)
        first = max(float(self.ends[0]) - now, 0.0)
        self._starts = [now, *self.ends[:-1].tolist()]
        self._spans = [first, *np.diff(self.ends).tolist()]
        # huge positions in a short time overflow: not_finite() says where, quietly
        with np.errstate(over="ignore", invalid="ignore"):
            coefficients = [
                _spline(np.asarray(position, dtype=float), v_now, a_now,
                        p[0], None if v is None else v[0], None if a is None else a[0], first)
            ]
            for k in range(1, self.n):
                coefficients.append(_spline(
                    p[k - 1], None if v is None else v[k - 1], None if a is None else a[k - 1],
                    p[k], None if v is None else v[k], None if a is None else a[k],
                    self._spans[k],
                ))
            self._position = [np.ascontiguousarray(c.T) for c in coefficients]  # joints x 6
            self._velocity = [np.ascontiguousarray((_DERIVE @ c).T) for c in coefficients]
            self._acceleration = [np.ascontiguousarray((_DERIVE @ _DERIVE @ c).T)
                                  for c in coefficients]
        self._before = np.array(position, dtype=float)
        self._before_v = np.zeros(self.dof) if velocity is None else np.array(velocity, float)
        self._powers = np.zeros(ORDER)
        e = self.effort
        # the state at the start has no effort of its own (ros2_controllers: zero)
        self._effort_start = [np.zeros(self.dof), *([] if e is None else list(e[:-1]))]

    def not_finite(self) -> tuple[int, int, float, float] | None:
        """After :meth:`begin`: where a sample could be other than finite, as (point,
        joint index, the position the spline to it starts from, its span in seconds):
        a spline whose coefficients overflow (a position too large for its time), or
        one that starts from a state that is not finite. None if every sample is
        finite. Once per trajectory, never in :meth:`sample`."""
        if not self.interpolate:
            return None  # the samples are the points (checked finite) and the state
        for k in range(self.n):
            for table in (self._position[k], self._velocity[k], self._acceleration[k]):
                bad = ~np.isfinite(table).all(axis=1)
                if bad.any():
                    j = int(bad.argmax())
                    before = self._before[j] if k == 0 else self.positions[k - 1, j]
                    return k, j, float(before), float(self._spans[k])
        return None

    def leaves(self, low: np.ndarray, high: np.ndarray,
               samples: int = 33) -> tuple[int, int, float] | None:
        """After :meth:`begin`, with finite samples (:meth:`not_finite`): where the
        positions between two points leave ``[low, high]`` (per joint; infinite: no
        limit), as (point it heads to, joint index, the position there), sampling each
        segment at ``samples`` evenly spaced times: a spline through points within the
        limits can swing out of them (velocities too large for the points' spacing).
        None if it stays within them. Once per trajectory, never in :meth:`sample`."""
        if not self.interpolate:
            return None  # the samples are the points, checked against the limits
        fractions = np.linspace(0.0, 1.0, samples)
        exponents = np.arange(ORDER)[:, None]
        for k in range(self.n):
            powers = (fractions * self._spans[k])[None, :] ** exponents  # ORDER x samples
            positions = self._position[k] @ powers  # joints x samples
            outside = (positions < low[:, None]) | (positions > high[:, None])
            if outside.any():
                j, s = np.unravel_index(int(outside.argmax()), outside.shape)
                return k, int(j), float(positions[j, s])
        return None

    def segment(self, t: float) -> int:
        """The index of the point that a sample at ``t`` heads to: 0 before the first
        point, ``n`` once the last point's time has come. Does not move the cursor."""
        k = self._cursor
        ends = self.ends
        if k > 0 and t < ends[k - 1]:
            k = 0  # earlier than the last sample: search from the start
        while k < self.n and t >= ends[k]:
            k += 1
        return k

    def sample(
        self,
        t: float,
        position: np.ndarray,
        velocity: np.ndarray,
        acceleration: np.ndarray,
        effort: np.ndarray | None = None,
        *,
        advance: bool = True,
    ) -> int:
        """Write the trajectory's state at ``t`` into the arrays; returns the index of
        the point it heads to (:meth:`segment`). ``advance``: remember the segment
        (samples then go forward from it), as the controller's sample of "now" does."""
        k = self.segment(t)
        if advance:
            self._cursor = k
            self.sampled = True
        if k >= self.n:  # played out: hold the last point
            position[:] = self.positions[-1]
            _fill(velocity, self.velocities)
            _fill(acceleration, self.accelerations)
            if effort is not None:
                _fill(effort, self.effort)
            return k
        if not self.interpolate:  # the next point as it is (the state before the first)
            if k == 0 and t < self.ends[0]:
                position[:] = self._before
                velocity[:] = self._before_v
                acceleration.fill(0.0)
            else:
                position[:] = self.positions[k]
                _fill(velocity, self.velocities, k)
                _fill(acceleration, self.accelerations, k)
            if effort is not None:
                _fill(effort, self.effort, k)
            return k
        tau = max(t - self._starts[k], 0.0)
        powers = self._powers
        x = 1.0
        for i in range(ORDER):
            powers[i] = x
            x *= tau
        np.dot(self._position[k], powers, out=position)
        np.dot(self._velocity[k], powers, out=velocity)
        np.dot(self._acceleration[k], powers, out=acceleration)
        if effort is not None:
            if self.effort is None:
                effort.fill(0.0)
            else:
                span = self._spans[k]
                w = tau / span if span > 0.0 else 1.0
                np.multiply(self._effort_start[k], 1.0 - w, out=effort)
                effort += w * self.effort[k]  # a new trajectory's efforts: rare, allowed
        return k


def hold(
    position: np.ndarray,
    velocity: np.ndarray | None,
    acceleration: np.ndarray | None,
    commands: Sequence[str],
    *,
    interpolate: bool = True,
) -> Trajectory:
    """A trajectory of one point, due at once: what the controller holds (ros2_controllers'
    hold message). Velocities (zero if not given) where a ``velocity`` or
    ``acceleration`` command needs them, accelerations where an ``acceleration`` one
    does, zero efforts for an ``effort`` one."""
    n = position.shape[0]
    if velocity is None and ("velocity" in commands or "acceleration" in commands):
        velocity = np.zeros(n)
    if acceleration is None and "acceleration" in commands:
        acceleration = np.zeros(n)
    effort = np.zeros((1, n)) if "effort" in commands else None
    return Trajectory(
        [0.0], position[None, :],
        None if velocity is None else velocity[None, :],
        None if acceleration is None else acceleration[None, :], effort,
        interpolate=interpolate)


def _fill(out: np.ndarray, values: np.ndarray | None, k: int = -1) -> None:
    if values is None:
        out.fill(0.0)
    else:
        out[:] = values[k]


def check(
    message: Any,
    joints: Sequence[str],
    *,
    allow_partial: bool,
    allow_nonzero_end_velocity: bool,
    allow_effort: bool,
    limits: JointLimits | None = None,
) -> str | None:
    """Why ``message`` (a ``trajectory_msgs/JointTrajectory``) cannot be followed by a
    controller of ``joints``, or None: ros2_controllers' ``validate_trajectory_msg``
    (its header stamp's "ends in the past" is :func:`from_message`'s caller's), and
    rtcf's own: every value finite, every ``time_from_start`` a duration >= 0, and
    every position inside ``limits`` (the joints' position limits) where given.
    The problem names the point, the joint and the value."""
    names = list(message.joint_names)
    if not allow_partial and len(names) != len(joints):
        return (f"its joint_names {names} are not the controller's joints {list(joints)} "
                "(allow_partial_joints_goal is false)")
    if not names:
        return "its joint_names are empty"
    points = message.points
    if not points:
        return "it has no points"
    unknown = [n for n in names if n not in joints]
    if unknown:
        return f"joint(s) {unknown} are not the controller's joints {list(joints)}"
    if len(set(names)) != len(names):
        return f"its joint_names {names} repeat a name"
    limited = [] if limits is None else [
        (c, name) for c, name in enumerate(names) if name in limits.position]
    isfinite = math.isfinite
    previous = -1.0
    for i, point in enumerate(points):
        wrong_time = duration_problem(point.time_from_start)
        if wrong_time is not None:
            return f"point {i} time_from_start is {wrong_time}"
        t = duration_s(point.time_from_start)
        if i > 0 and t <= previous:
            return (f"time_from_start of points {i - 1} and {i} ({previous:g} s, {t:g} s) "
                    "does not increase")
        previous = t
        for field, empty_ok in (("positions", False), ("velocities", True),
                                ("accelerations", True)):
            values = getattr(point, field)
            if not (empty_ok and len(values) == 0) and len(values) != len(names):
                return (f"point {i} has {len(values)} {field} for {len(names)} joints")
        if len(point.effort) and not allow_effort:
            return (f"point {i} has effort, which only a controller with the 'effort' "
                    "command interface takes")
        if len(point.effort) and len(point.effort) != len(names):
            return f"point {i} has {len(point.effort)} effort for {len(names)} joints"
        for field, kind in _FIELDS:
            values = getattr(point, field)
            if not all(map(isfinite, values)):  # one pass in C; the culprit only if needed
                c = next(c for c, v in enumerate(values) if not isfinite(v))
                return f"point {i} {kind} of {names[c]} is {float(values[c])!r} (not finite)"
        for c, name in limited:
            assert limits is not None
            outside = limits.outside(name, "position", float(point.positions[c]))
            if outside is not None:
                return f"point {i} position of {name} is {outside}"
    if not allow_nonzero_end_velocity:
        for name, v in zip(names, points[-1].velocities, strict=False):
            if abs(v) > np.finfo(np.float32).eps:
                return (f"the last point's velocity of {name} is {v}, not 0 "
                        "(allow_nonzero_velocity_at_trajectory_end is false)")
    return None


def from_message(
    message: Any,
    joints: Sequence[str],
    held: Callable[[int], float],
    *,
    start: float | None,
    interpolate: bool = True,
) -> Trajectory:
    """A checked message (:func:`check`) as a :class:`Trajectory` in ``joints``' order.
    Joints a partial goal leaves out hold ``held(joint index)`` with zero velocity,
    acceleration and effort, as ros2_controllers' ``fill_partial_goal`` does.
    Fields go by the first point: a field some points lack counts as absent."""
    names = list(message.joint_names)
    points = message.points
    n, dof = len(points), len(joints)
    column = [names.index(j) if j in names else -1 for j in joints]

    def table(field: str) -> np.ndarray | None:
        if any(len(getattr(p, field)) == 0 for p in points):
            return None
        out = np.zeros((n, dof))
        for i, p in enumerate(points):
            values = getattr(p, field)
            for j, c in enumerate(column):
                if c >= 0:
                    out[i, j] = values[c]
                elif field == "positions":
                    out[i, j] = held(j)
        return out

    positions = table("positions")
    assert positions is not None  # check() requires them
    return Trajectory(
        [duration_s(p.time_from_start) for p in points],
        positions, table("velocities"), table("accelerations"), table("effort"),
        start=start, interpolate=interpolate,
    )
