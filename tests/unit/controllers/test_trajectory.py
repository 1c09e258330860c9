"""rtcf_controllers._trajectory: the splines joint_trajectory_controller samples, against
hand computations, and the checks and joint order of trajectory messages."""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

from rtcf_controllers._limits import JointLimits
from rtcf_controllers._trajectory import Trajectory, check, from_message


def _sample(traj: Trajectory, t: float, dof: int = 1) -> tuple[list, list, list, int]:
    p, v, a = np.zeros(dof), np.zeros(dof), np.zeros(dof)
    k = traj.sample(t, p, v, a)
    return p.tolist(), v.tolist(), a.tolist(), k


def _pva(traj: Trajectory, t: float) -> list[float]:
    """Position, velocity and acceleration of a one-joint trajectory at ``t``."""
    p, v, a, _ = _sample(traj, t)
    return [p[0], v[0], a[0]]


def test_positions_only_is_linear_from_the_state_at_the_start_then_holds_the_end() -> None:
    traj = Trajectory([1.0, 3.0], [[1.0], [2.0]])
    traj.begin(10.0, np.array([0.0]), np.array([5.0]))  # the state's velocity: unused
    assert _sample(traj, 10.5) == ([0.5], [1.0], [0.0], 0)
    assert _sample(traj, 12.0) == ([1.5], [0.5], [0.0], 1)
    assert _sample(traj, 13.0) == ([2.0], [0.0], [0.0], 2)  # the last point, held
    assert _sample(traj, 99.0)[0] == [2.0]
    assert traj.end_time == 13.0


def test_velocities_make_it_cubic_from_the_measured_velocity() -> None:
    traj = Trajectory([2.0], [[1.0]], velocities=[[0.0]])
    traj.begin(0.0, np.array([0.0]), np.array([0.0]))
    # p = 3/4 t^2 - 1/4 t^3
    assert _sample(traj, 1.0)[3] == 0
    assert _pva(traj, 1.0) == pytest.approx([0.5, 0.75, 0.0])
    moving = Trajectory([2.0], [[1.0]], velocities=[[0.0]])
    moving.begin(0.0, np.array([0.0]), np.array([1.0]))
    # p = t - 1/4 t^2: the velocity at the start is the state's
    assert _pva(moving, 1.0) == pytest.approx([0.75, 0.5, -0.5])


def test_a_state_without_velocity_counts_as_still_when_the_points_have_velocities() -> None:
    traj = Trajectory([2.0], [[1.0]], velocities=[[0.0]])
    traj.begin(0.0, np.array([0.0]))  # no velocity state interface
    assert _pva(traj, 1.0)[:2] == pytest.approx([0.5, 0.75])


def test_accelerations_make_it_quintic() -> None:
    traj = Trajectory([1.0], [[1.0]], velocities=[[0.0]], accelerations=[[0.0]])
    traj.begin(0.0, np.array([0.0]), np.array([0.0]))
    # p = 10 t^3 - 15 t^4 + 6 t^5
    assert _sample(traj, 0.25)[0] == pytest.approx([0.103515625])
    assert _pva(traj, 0.5) == pytest.approx([0.5, 1.875, 0.0])


@pytest.mark.parametrize("fields", ["p", "pv", "pva"])
def test_every_segment_meets_its_points_with_their_derivatives(fields: str) -> None:
    rng = np.random.default_rng(len(fields))
    times = [0.5, 1.25, 2.0, 3.5]
    p = rng.normal(size=(4, 3))
    v = rng.normal(size=(4, 3)) if "v" in fields else None
    a = rng.normal(size=(4, 3)) if "a" in fields else None
    if v is not None:
        v[-1] = 0.0
    traj = Trajectory(times, p, v, a)
    traj.begin(0.0, np.zeros(3), np.zeros(3), np.zeros(3))
    for k, t in enumerate(times):
        pos, vel, acc, _ = _sample(traj, t - 1e-9, 3)  # the end of the segment before
        assert pos == pytest.approx(p[k], abs=1e-6)
        if v is not None:
            assert vel == pytest.approx(v[k], abs=1e-6)
        if a is not None:
            assert acc == pytest.approx(a[k], abs=1e-5)


def test_a_start_in_the_future_stretches_the_first_segment() -> None:
    traj = Trajectory([1.0], [[4.0]], start=3.0)
    traj.begin(2.0, np.array([0.0]))
    assert _sample(traj, 3.0)[0] == pytest.approx([2.0])  # halfway from 2 s to 4 s


def test_no_interpolation_gives_the_next_point() -> None:
    traj = Trajectory([1.0, 2.0], [[1.0], [2.0]], interpolate=False)
    traj.begin(0.0, np.array([0.5]))
    assert _sample(traj, 0.5)[0] == [0.5]
    assert _sample(traj, 1.5)[0] == [2.0]


def test_sampling_ahead_does_not_move_the_cursor() -> None:
    traj = Trajectory([1.0, 2.0, 3.0], [[1.0], [2.0], [3.0]])
    traj.begin(0.0, np.array([0.0]))
    p, v, a = np.zeros(1), np.zeros(1), np.zeros(1)
    assert traj.sample(2.5, p, v, a, advance=False) == 2
    assert traj.sample(0.5, p, v, a) == 0 and p[0] == pytest.approx(0.5)


def test_effort_is_linear() -> None:
    traj = Trajectory([2.0], [[1.0]], effort=[[4.0]])
    traj.begin(0.0, np.array([0.0]))
    p, v, a, e = np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1)
    traj.sample(0.5, p, v, a, e)
    assert e[0] == pytest.approx(1.0)


def _point(t: float, positions=(), velocities=(), accelerations=(), effort=()) -> NS:
    return NS(time_from_start=NS(sec=int(t), nanosec=round((t % 1) * 1e9)),
              positions=list(positions), velocities=list(velocities),
              accelerations=list(accelerations), effort=list(effort))


def _msg(names: list[str], *points: NS) -> NS:
    return NS(joint_names=names, points=list(points))


JOINTS = ["a", "b", "c"]


def _check(msg: NS, partial: bool = False, nonzero_end: bool = False) -> str | None:
    return check(msg, JOINTS, allow_partial=partial, allow_nonzero_end_velocity=nonzero_end,
                 allow_effort=False)


@pytest.mark.parametrize(("msg", "partial", "why"), [
    (_msg(["a", "b"], _point(1, [0, 0])), False, "allow_partial_joints_goal"),
    (_msg(["a", "x", "c"], _point(1, [0, 0, 0])), False, "['x'] are not"),
    (_msg(["a", "x"], _point(1, [0, 0])), True, "['x'] are not"),
    (_msg(["a", "b", "c"]), False, "no points"),
    (_msg([], _point(1, [])), True, "empty"),
    (_msg(["a", "b", "c"], _point(1, [0, 0, 0]), _point(1, [1, 1, 1])), False, "increase"),
    (_msg(["a", "b", "c"], _point(1, [0, 0])), False, "2 positions for 3"),
    (_msg(["a", "b", "c"], _point(1, [0, 0, 0], [0, 1, 0])), False, "velocity of b"),
    (_msg(["a", "b", "c"], _point(1, [0, 0, 0], effort=[1, 1, 1])), False, "effort"),
])
def test_check_refuses_what_the_controller_refuses(msg: NS, partial: bool, why: str) -> None:
    problem = _check(msg, partial)
    assert problem is not None and why in problem


def test_check_accepts_partial_goals_with_the_flag_and_end_velocity_with_its_flag() -> None:
    assert _check(_msg(["c", "a"], _point(1, [0, 0])), partial=True) is None
    moving = _msg(["a", "b", "c"], _point(1, [0, 0, 0], [0, 1, 0]))
    assert _check(moving, nonzero_end=True) is None


def test_from_message_orders_joints_and_holds_those_a_partial_goal_leaves_out() -> None:
    msg = _msg(["c", "a"], _point(0.5, [3.0, 1.0], [0.3, 0.1]), _point(1.5, [6.0, 2.0], [0, 0]))
    traj = from_message(msg, JOINTS, lambda j: 10.0 * (j + 1), start=None)
    assert traj.times.tolist() == [0.5, 1.5]
    assert traj.positions.tolist() == [[1.0, 20.0, 3.0], [2.0, 20.0, 6.0]]
    assert traj.velocities is not None
    assert traj.velocities.tolist() == [[0.1, 0.0, 0.3], [0.0, 0.0, 0.0]]
    assert traj.accelerations is None and traj.effort is None


# -- input that must never reach a command: refused, naming the point, joint and value
def _limits() -> JointLimits:
    return JointLimits({"b": (-3.14, 3.14)}, {}, {})


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(("msg", "why"), [
    (_msg(JOINTS, _point(1, [0, NAN, 0])), "point 0 position of b is nan (not finite)"),
    (_msg(JOINTS, _point(1, [0, 0, 0]), _point(2, [0, 0, -INF])),
     "point 1 position of c is -inf (not finite)"),
    (_msg(JOINTS, _point(1, [0, 0, 0], [NAN, 0, 0])),
     "point 0 velocity of a is nan (not finite)"),
    (_msg(JOINTS, _point(1, [0, 0, 0], [0, 0, 0], [0, INF, 0])),
     "point 0 acceleration of b is inf (not finite)"),
    (_msg(JOINTS, _point(1, [0, 0, 0], effort=[0, 0, NAN])),
     "point 0 effort of c is nan (not finite)"),
    (_msg(JOINTS, NS(time_from_start=NS(sec=-1, nanosec=0), positions=[0, 0, 0],
                     velocities=[], accelerations=[], effort=[])),
     "point 0 time_from_start is -1 s 0 ns (negative)"),
    (_msg(JOINTS, _point(1, [0, 0, 0]),
          NS(time_from_start=NS(sec=2, nanosec=1_000_000_000), positions=[0, 0, 0],
             velocities=[], accelerations=[], effort=[])),
     "point 1 time_from_start is 2 s 1000000000 ns (nanoseconds out of [0, 1e9))"),
    (_msg(JOINTS, _point(1, [0, 4.2, 0])),
     "point 0 position of b is 4.2, outside its limits [-3.14, 3.14] (joint_limits.b)"),
    (_msg(["c", "b"], _point(1, [1e300, 1e300])),
     "point 0 position of b is 1e+300, outside its limits [-3.14, 3.14] (joint_limits.b)"),
])
def test_check_refuses_values_that_are_not_finite_bad_times_and_positions_off_limits(
    msg: NS, why: str
) -> None:
    problem = check(msg, JOINTS, allow_partial=True, allow_nonzero_end_velocity=True,
                    allow_effort=True, limits=_limits())
    assert problem == why


def test_check_takes_positions_within_the_limits_and_no_limits_at_all() -> None:
    inside = _msg(JOINTS, _point(1, [9.0, 3.14, -9.0]))
    assert _check(inside) is None
    assert check(inside, JOINTS, allow_partial=False, allow_nonzero_end_velocity=False,
                 allow_effort=False, limits=_limits()) is None


def test_a_roslike_ros1_duration_is_checked_too() -> None:
    point = NS(time_from_start=NS(secs=-2, nsecs=500), positions=[0, 0, 0], velocities=[],
               accelerations=[], effort=[])
    assert _check(_msg(JOINTS, point)) == "point 0 time_from_start is -2 s 500 ns (negative)"


@pytest.mark.parametrize("fields", ["p", "pv", "pva"])
def test_splines_whose_coefficients_overflow_are_found_before_any_sample(fields: str) -> None:
    # finite, but 1e300 in 1 ms overflows a cubic's and quintic's coefficients; a
    # linear one's velocity stays finite (1e303) and is not refused here
    v = [[0.0], [0.0]] if "v" in fields else None
    a = [[0.0], [0.0]] if "a" in fields else None
    traj = Trajectory([0.001, 1.0], [[1e300], [0.0]], v, a)
    traj.begin(0.0, np.array([0.0]), np.array([0.0]), np.array([0.0]))
    found = traj.not_finite()
    if fields == "p":
        assert found is None
    else:
        assert found == (0, 0, 0.0, pytest.approx(0.001))


def test_a_state_that_is_not_finite_makes_the_first_spline_not_finite() -> None:
    traj = Trajectory([1.0], [[1.0]], velocities=[[0.0]])
    traj.begin(0.0, np.array([0.0]), np.array([float("nan")]))
    assert traj.not_finite() == (0, 0, 0.0, 1.0)
    fine = Trajectory([1.0], [[1.0]], velocities=[[0.0]])
    fine.begin(0.0, np.array([0.0]), np.array([0.0]))
    assert fine.not_finite() is None
