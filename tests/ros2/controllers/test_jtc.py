"""joint_trajectory_controller in-process (rtcf.testing, simulated clock) on a kinematic
arm: the topic, the splines against hand computations, controller_state, cmd_timeout,
and the follow_joint_trajectory action's goals (success with feedback, rejections,
tolerances, preemption, cancel). Needs control_msgs: Python 3.11's .venv-ros2."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import rtcf
from rtcf import GoalStatus, Rate
from rtcf.testing import Cancel, Goal, Trace, run_components, run_launch
from rtcf_controllers.joint_trajectory_controller import JointTrajectoryController

from ._plants import PositionJoints

HZ = 100.0
JOINTS = ["a", "b"]
TOPIC = "/jtc/joint_trajectory"
ACTION = "/jtc/follow_joint_trajectory"


class Kinematic(PositionJoints):
    """Joints that go where they were commanded one iteration before (first in the
    loop, as hardware is), until ``~stuck_s``: from then on they stay where they are."""

    def configure(self) -> None:
        super().configure()
        self.stuck_s = float(self.params.get("~stuck_s", 1e9))
        self.still = np.zeros_like(self.q)

    def update(self) -> None:
        if self.time < self.stuck_s:
            super().update()
        else:
            self.position.write(self.q)
            self.velocity.write(self.still)


def _duration(seconds: float) -> Duration:
    sec, fraction = divmod(seconds, 1.0)  # -0.5 s: -1 s + 500000000 ns, as ROS writes it
    return Duration(sec=int(sec), nanosec=round(fraction * 1e9))


def _trajectory(names: list[str], *points: tuple) -> JointTrajectory:
    """points: (time_from_start, positions[, velocities[, accelerations]])"""
    msg = JointTrajectory(joint_names=names)
    for t, *fields in points:
        point = JointTrajectoryPoint(time_from_start=_duration(t), positions=list(fields[0]))
        if len(fields) > 1:
            point.velocities = list(fields[1])
        if len(fields) > 2:
            point.accelerations = list(fields[2])
        msg.points.append(point)
    return msg


def _run(iterations: int, params: dict[str, Any] | None = None, *, plant: dict | None = None,
         inputs: dict | None = None, actions: dict | None = None) -> Trace:
    jtc = {"joints": JOINTS, "command_interfaces": ["position"],
           "state_interfaces": ["position", "velocity"], **(params or {})}
    plant = {"initial_positions": [0.0, 0.0], **(plant or {})}
    specs = [rtcf.ComponentSpec("arm", Kinematic, params=plant, is_first=True),
             rtcf.ComponentSpec("jtc", JointTrajectoryController, params=jtc)]
    return run_components(specs, iterations, frequency=HZ, inputs=inputs, actions=actions)


def _once(msg: Any) -> Any:
    """A topic input that carries ``msg`` in iteration 0 and nothing after."""
    return lambda i, t: msg if i == 0 else None


def _positions(trace: Trace, k: int) -> list[float]:
    return trace.outputs["/position"][k].tolist()


@pytest.mark.parametrize(("fields", "at_quarter"), [
    ((), 0.25),                            # linear: t
    (([0, 0],), 0.15625),                  # cubic: 3t^2 - 2t^3
    (([0, 0], [0, 0]), 0.103515625),       # quintic: 10t^3 - 15t^4 + 6t^5
])
def test_the_topic_interpolates_by_the_fields_given(fields: tuple, at_quarter: float) -> None:
    msg = _trajectory(JOINTS, (1.0, [1.0, -2.0], *fields))
    trace = _run(120, inputs={TOPIC: _once(msg)})
    # the arm is where the controller commanded it one period ahead: on the spline
    assert _positions(trace, 25) == pytest.approx([at_quarter, -2 * at_quarter])
    assert _positions(trace, 50) == pytest.approx([0.5, -1.0])
    assert _positions(trace, 119) == pytest.approx([1.0, -2.0])  # held at the end


def test_a_topic_trajectory_names_joints_in_any_order_and_bad_ones_are_ignored(
    caplog: pytest.LogCaptureFixture,
) -> None:
    swapped = _trajectory(["b", "a"], (0.5, [2.0, 1.0]))
    trace = _run(60, inputs={TOPIC: _once(swapped)})
    assert _positions(trace, 59) == pytest.approx([1.0, 2.0])
    unknown = _trajectory(["a", "x"], (0.5, [2.0, 1.0]))
    trace = _run(60, inputs={TOPIC: _once(unknown)})
    assert _positions(trace, 59) == [0.0, 0.0]
    assert "~/joint_trajectory ignored" in caplog.text and "'x'" in caplog.text


def test_controller_state_reports_reference_feedback_and_error() -> None:
    msg = _trajectory(JOINTS, (1.0, [1.0, -2.0]))
    trace = _run(40, {"state_publish_rate": 50.0}, plant={"stuck_s": 0.2},
                 inputs={TOPIC: _once(msg)})
    states = trace.outputs["/jtc/controller_state"]
    stamps = [s.header.stamp.nanosec for s in states[:4]]
    assert stamps == [0, 0, 20_000_000, 20_000_000]  # every other iteration at 100 Hz
    state = states[30]
    assert list(state.joint_names) == JOINTS
    assert list(state.reference.positions) == pytest.approx([0.3, -0.6])
    assert list(state.feedback.positions) == pytest.approx([0.19, -0.38])  # stuck at 0.2 s
    assert list(state.error.positions) == pytest.approx([0.11, -0.22])
    assert list(state.output.positions) == pytest.approx([0.31, -0.62])


def test_cmd_timeout_holds_where_the_arm_is_once_the_end_is_that_old() -> None:
    msg = _trajectory(JOINTS, (0.5, [1.0, 1.0]))
    trace = _run(100, {"cmd_timeout": 0.2}, plant={"stuck_s": 0.3},
                 inputs={TOPIC: _once(msg)})
    commands = trace.outputs["/position_command"]
    assert commands[65].tolist() == [1.0, 1.0]  # past the end, within the timeout
    assert commands[99].tolist() == pytest.approx([0.58, 0.58])  # held where it got stuck


def test_a_lone_effort_command_goes_through_the_pid() -> None:
    msg = _trajectory(JOINTS, (1.0, [1.0, 2.0]))
    gains = {"a": {"p": 100.0, "i": 10.0, "d": 5.0}, "b": {"p": 1.0}}
    trace = _run(11, {"command_interfaces": ["effort"], "gains": gains},
                 plant={"stuck_s": 0.0}, inputs={TOPIC: _once(msg)})
    # the arm stays at 0: errors [t, 2t] and [1, 2]/s; the integral sums i dt e
    integral = 10.0 * 0.01 * sum(0.01 * k for k in range(11))
    effort = trace.outputs["/effort_command"][10].tolist()
    assert effort == pytest.approx([100.0 * 0.1 + integral + 5.0 * 1.0, 1.0 * 0.2])


# -- the follow_joint_trajectory action ---------------------------------------------------
Result = FollowJointTrajectory.Result


def _goal(trajectory: JointTrajectory, *, path: dict | None = None, goal_time: float = 0.0,
          id: int = 1) -> Goal:
    tolerances = [JointTolerance(name=n, position=p) for n, p in (path or {}).items()]
    return Goal(FollowJointTrajectory.Goal(
        trajectory=trajectory, path_tolerance=tolerances,
        goal_time_tolerance=_duration(goal_time)), id=id)


def _goals(trace: Trace) -> dict[int, Any]:
    return trace.actions[ACTION].goals


GOAL_TOLERANCE = {"constraints": {"a": {"goal": 0.01}, "b": {"goal": 0.01}}}


def test_a_goal_reaches_its_end_successfully_with_feedback_at_the_monitor_rate() -> None:
    goal = _goal(_trajectory(JOINTS, (0.5, [1.0, -1.0])))
    trace = _run(70, GOAL_TOLERANCE, actions={ACTION: {0: goal}})
    record = _goals(trace)[goal.id]
    assert record.accepted and record.status == GoalStatus.SUCCEEDED
    assert record.result.error_code == Result.SUCCESSFUL
    assert record.states[-1][0] in (49, 50)  # the last point's time has come
    iterations = [i for i, _ in record.feedback]
    assert iterations == list(range(0, iterations[-1] + 1, 5))  # 20 Hz at 100 Hz
    feedback = record.feedback[2][1]  # iteration 10, t = 0.1 s
    assert list(feedback.joint_names) == JOINTS
    assert list(feedback.desired.positions) == pytest.approx([0.2, -0.2])
    assert list(feedback.actual.positions) == pytest.approx([0.2, -0.2])
    assert _positions(trace, 69) == pytest.approx([1.0, -1.0])


def test_feedback_and_state_at_their_rates_when_the_controller_runs_slower() -> None:
    goal = _goal(_trajectory(JOINTS, (1.0, [1.0, -1.0])))
    jtc = {"joints": JOINTS, "command_interfaces": ["position"],
           "state_interfaces": ["position", "velocity"], "action_monitor_rate": 10.0,
           "state_publish_rate": 25.0}
    specs = [rtcf.ComponentSpec("arm", Kinematic, params={"initial_positions": [0.0, 0.0]},
                                is_first=True),
             rtcf.ComponentSpec("jtc", JointTrajectoryController, params=jtc,
                                rate=Rate(rate=50.0, phase=0))]  # every other iteration
    trace = run_components(specs, 60, frequency=HZ, actions={ACTION: {0: goal}})
    assert [i for i, _ in _goals(trace)[goal.id].feedback] == [0, 10, 20, 30, 40, 50]
    stamps = {s.header.stamp.nanosec // 10_000_000 for s in trace.outputs["/jtc/controller_state"]}
    assert sorted(stamps) == [0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40, 44, 48, 52, 56]


def test_a_goal_naming_an_unknown_joint_is_rejected_and_nothing_moves() -> None:
    goal = _goal(_trajectory(["a", "x"], (0.5, [1.0, -1.0])))
    trace = _run(20, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].accepted is False
    assert _positions(trace, 19) == [0.0, 0.0]


@pytest.mark.parametrize("partial", [False, True])
def test_a_partial_goal_follows_allow_partial_joints_goal(partial: bool) -> None:
    goal = _goal(_trajectory(["b"], (0.3, [1.0])))
    trace = _run(40, {"allow_partial_joints_goal": partial},
                 plant={"initial_positions": [0.5, 0.0]}, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].accepted is partial
    assert _positions(trace, 39) == pytest.approx([0.5, 1.0] if partial else [0.5, 0.0])


def test_a_path_violation_aborts_and_the_arm_holds_where_it_is() -> None:
    goal = _goal(_trajectory(JOINTS, (1.0, [1.0, -2.0])), path={"a": 0.05})
    trace = _run(60, plant={"stuck_s": 0.2}, actions={ACTION: {0: goal}})
    record = _goals(trace)[goal.id]
    assert record.status == GoalStatus.ABORTED
    assert record.result.error_code == Result.PATH_TOLERANCE_VIOLATED
    aborted = record.states[-1][0]
    assert 24 <= aborted <= 26  # 0.05 behind the stuck arm (0.19)
    commands = trace.outputs["/position_command"]
    assert commands[aborted] is commands[aborted - 1]  # no command from the violating sample
    assert commands[59].tolist() == pytest.approx([0.19, -0.38])


def test_outside_the_goal_tolerance_after_goal_time_aborts() -> None:
    goal = _goal(_trajectory(JOINTS, (0.5, [1.0, 1.0])), goal_time=0.1)
    trace = _run(80, GOAL_TOLERANCE, plant={"stuck_s": 0.45}, actions={ACTION: {0: goal}})
    record = _goals(trace)[goal.id]
    assert record.result.error_code == Result.GOAL_TOLERANCE_VIOLATED
    assert 59 <= record.states[-1][0] <= 62  # 0.1 s after the last point's time


def test_a_newer_goal_preempts_the_running_one() -> None:
    first = _goal(_trajectory(JOINTS, (1.0, [1.0, 1.0])), id=1)
    second = _goal(_trajectory(JOINTS, (0.5, [-1.0, -1.0])), id=2)
    trace = _run(90, actions={ACTION: {0: first, 20: second}})
    goals = _goals(trace)
    assert goals[1].states[-1] == (20, GoalStatus.ABORTED)
    assert goals[1].result.error_code == Result.INVALID_GOAL
    assert "preempted" in goals[1].result.error_string
    assert goals[2].status == GoalStatus.SUCCEEDED
    assert _positions(trace, 89) == pytest.approx([-1.0, -1.0])


def test_a_cancel_holds_position() -> None:
    goal = _goal(_trajectory(JOINTS, (1.0, [1.0, 1.0])))
    trace = _run(60, actions={ACTION: {0: goal, 30: Cancel(goal.id)}})
    record = _goals(trace)[goal.id]
    assert record.cancel_accepted and record.status == GoalStatus.CANCELED
    assert _positions(trace, 59) == pytest.approx([0.3, 0.3])


def test_a_goal_running_when_the_controller_stops_is_aborted_as_invalid() -> None:
    goal = _goal(_trajectory(JOINTS, (1.0, [1.0, 1.0])))
    record = _goals(_run(20, actions={ACTION: {0: goal}}))[goal.id]
    assert record.status == GoalStatus.ABORTED
    assert record.result.error_code == Result.INVALID_GOAL
    assert "deactivate" in record.result.error_string


# -- the arm example on ros2_controllers' controllers (MuJoCo) ------------------------------
ARM_ACTION = "/arm_controller/follow_joint_trajectory"


@pytest.mark.parametrize("file", ["arm.launch", "arm.launch.xml"])
def test_the_arm_example_on_ros2_controllers_reaches_a_goal_given_through_the_action(
    file: str,
) -> None:
    names = ["joint3", "joint1", "joint2"]  # any order, as clients send them
    goal = _goal(_trajectory(names, (1.0, [0.8, 0.5, -0.2])))
    trace = run_launch(f"rtcf_examples {file}", 1400, args={"ros2_controllers": "true"},
                       actions={ARM_ACTION: {100: goal}})
    record = trace.actions[ARM_ACTION].goals[goal.id]
    assert record.status == GoalStatus.SUCCEEDED and record.feedback
    assert trace.outputs["/arm/position"][99].tolist() == pytest.approx([0.0, 0.3, 0.6], abs=1e-3)
    assert trace.outputs["/arm/position"][-1].tolist() == pytest.approx([0.5, -0.2, 0.8], abs=0.02)
    states = trace.outputs["/joint_states"][-1]  # rtcf_controllers' joint_state_broadcaster
    assert list(states.name) == ["joint1", "joint2", "joint3"]


# -- bad input never reaches the hardware (issue 38) --------------------------------------
NAN, INF = float("nan"), float("inf")
LIMITS = {"joint_limits": {"b": {"has_position_limits": True, "min_position": -3.14,
                                 "max_position": 3.14}}}


def _all_finite(trace: Trace, topic: str = "/position_command") -> bool:
    return all(c is None or np.isfinite(c).all() for c in trace.outputs[topic])


@pytest.mark.parametrize(("points", "params", "why"), [
    (((0.5, [NAN, 1.0]),), {}, "point 0 position of a is nan (not finite)"),
    (((0.5, [0.5, 1.0]), (1.0, [1.0, INF])), {}, "point 1 position of b is inf (not finite)"),
    (((0.5, [0.5, 1.0], [NAN, 0.0]), (1.0, [1.0, 1.0], [0.0, 0.0])), {},
     "point 0 velocity of a is nan (not finite)"),
    (((-0.5, [0.5, 1.0]),), {}, "point 0 time_from_start is -1 s 500000000 ns (negative)"),
    (((0.5, [0.0, 1e300]),), LIMITS,
     "point 0 position of b is 1e+300, outside its limits [-3.14, 3.14] (joint_limits.b)"),
    (((0.5, [0.0, 4.2]),), LIMITS,
     "point 0 position of b is 4.2, outside its limits [-3.14, 3.14] (joint_limits.b)"),
    # no limits: finite, but a cubic to 1e300 in 1 ms overflows
    (((0.001, [0.0, 1e300], [0.0, 0.0]),), {},
     "point 0 position of b is 1e+300: the spline to it from 0.0 in 0.001 s is not finite "
     "(too far for its time, or a state that is not finite)"),
])
def test_a_goal_with_a_bad_value_is_rejected_naming_point_joint_and_value(
    points: tuple, params: dict, why: str, caplog: pytest.LogCaptureFixture,
) -> None:
    goal = _goal(_trajectory(JOINTS, *points), id=3)
    trace = _run(60, params, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].accepted is False
    assert f"goal 3 rejected: {why}" in [r.getMessage() for r in caplog.records]
    assert trace.components["/jtc"].refused_messages == {
        "~/joint_trajectory": 0, "~/follow_joint_trajectory": 1}
    assert _all_finite(trace) and _positions(trace, 59) == [0.0, 0.0]  # never moved


def test_a_goal_whose_spline_swings_out_of_the_limits_is_rejected(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Its points are within the limits, but a velocity too large for their spacing
    swings the cubic between them out (found by the fuzz: 4e294 on the command)."""
    goal = _goal(_trajectory(JOINTS, (0.5, [0.0, 1.0], [0.0, 100.0]),
                             (1.0, [0.0, 1.0], [0.0, 0.0])), id=4)
    trace = _run(60, LIMITS, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].accepted is False
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("goal 4")]
    assert len(said) == 1
    assert said[0].startswith("goal 4 rejected: its spline to point 0 takes b to -")
    assert said[0].endswith(", outside its limits [-3.14, 3.14] (joint_limits.b): too fast "
                            "for the points' spacing")
    assert _positions(trace, 59) == [0.0, 0.0]  # never moved


def test_a_huge_position_without_limits_never_makes_a_command_that_is_not_finite() -> None:
    goal = _goal(_trajectory(JOINTS, (1.0, [0.0, 1e300])))  # linear: finite all the way
    trace = _run(120, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].accepted and _all_finite(trace)
    assert _positions(trace, 119) == [0.0, 1e300]


def test_a_topic_trajectory_with_nan_is_ignored_and_counted_and_the_last_one_goes_on(
    caplog: pytest.LogCaptureFixture,
) -> None:
    good = _trajectory(JOINTS, (0.5, [1.0, 1.0]))
    bad = _trajectory(JOINTS, (0.5, [NAN, 0.0]))
    trace = _run(80, inputs={TOPIC: lambda i, t: good if i == 0 else bad if i in (20, 21)
                             else None})
    assert _all_finite(trace) and _positions(trace, 79) == pytest.approx([1.0, 1.0])
    assert trace.components["/jtc"].refused_messages["~/joint_trajectory"] == 2
    assert [r.getMessage() for r in caplog.records if "ignored" in r.getMessage()] == [
        "~/joint_trajectory ignored: point 0 position of a is nan (not finite); the current "
        "trajectory goes on"]  # the second within the second: counted, not logged


def test_a_nan_tolerance_runs_the_goal_on_the_defaults_and_says_so(
    caplog: pytest.LogCaptureFixture,
) -> None:
    goal = _goal(_trajectory(JOINTS, (0.5, [1.0, 1.0])), path={"a": NAN})
    trace = _run(70, GOAL_TOLERANCE, actions={ACTION: {0: goal}})
    assert _goals(trace)[goal.id].status == GoalStatus.SUCCEEDED
    assert ("goal 1 runs on the default tolerances: path_tolerance of 'a': position nan is "
            "illegal (not finite)") in caplog.text


@pytest.mark.parametrize(("limits", "words"), [
    ({"b": {"has_position_limits": True, "min_position": 1.0, "max_position": 0.0}},
     "'joint_limits.b.min_position' is 1.0; give a number <= joint_limits.b.max_position 0.0"),
    ({"a": {"has_position_limits": True, "min_position": -INF, "max_position": 0.0}},
     "'joint_limits.a.min_position' is -inf; give a finite number"),
])
def test_limits_that_cannot_be_are_refused_at_configure(limits: dict, words: str) -> None:
    with pytest.raises(rtcf.RtcfError) as caught:
        _run(1, {"joint_limits": limits})
    assert words in str(caught.value)


class GoesNan(Kinematic):
    """Kinematic joints whose position sensor reads NaN from ``~nan_s`` on."""

    def update(self) -> None:
        super().update()
        if self.time >= float(self.params.get("~nan_s", 1e9)):
            self.position.write(np.full_like(self.q, NAN))


def test_a_command_that_is_not_finite_is_never_written_and_a_running_goal_aborts(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # a lone effort command goes through the PID, whose error is NaN once the state is
    goal = _goal(_trajectory(JOINTS, (1.0, [1.0, 1.0])))
    jtc = {"joints": JOINTS, "command_interfaces": ["effort"], "gains": {"a": {"p": 1.0},
           "b": {"p": 1.0}}, "state_interfaces": ["position", "velocity"]}
    specs = [rtcf.ComponentSpec("arm", GoesNan, params={"initial_positions": [0.0, 0.0],
                                                        "nan_s": 0.3}, is_first=True),
             rtcf.ComponentSpec("jtc", JointTrajectoryController, params=jtc)]
    trace = run_components(specs, 60, frequency=HZ, actions={ACTION: {0: goal}})
    efforts = trace.outputs["/effort_command"]
    assert _all_finite(trace, "/effort_command") and efforts[29] is not None
    assert efforts[59] is efforts[29]  # the last finite command stays
    record = _goals(trace)[goal.id]
    assert record.states[-1] == (30, GoalStatus.ABORTED)
    assert record.result.error_code == Result.INVALID_GOAL
    controller = trace.components["/jtc"]
    assert controller.refused_samples == 30
    lines = [r.getMessage() for r in caplog.records if "not written" in r.getMessage()]
    assert lines == ["effort_command not written: the command [nan nan] is not finite; the "
                     "last command stays, holding position"]


@pytest.mark.parametrize("file", ["arm.launch", "arm.launch.xml"])
@pytest.mark.parametrize(("position", "why"), [
    (NAN, "point 0 position of joint2 is nan (not finite)"),
    (1e300, "point 0 position of joint2 is 1e+300, outside its limits [-2.0, 2.0] "
            "(joint_limits.joint2)"),
])
def test_the_arm_example_rejects_a_goal_the_arm_cannot_take(
    file: str, position: float, why: str, caplog: pytest.LogCaptureFixture,
) -> None:
    # issue 38's report: such a goal was accepted and MuJoCo went unstable
    goal = _goal(_trajectory(["joint1", "joint2", "joint3"], (1.0, [0.0, position, 0.6])))
    trace = run_launch(f"rtcf_examples {file}", 300, args={"ros2_controllers": "true"},
                       actions={ARM_ACTION: {100: goal}})
    assert trace.actions[ARM_ACTION].goals[goal.id].accepted is False
    assert f"goal 1 rejected: {why}" in caplog.text
    for topic in ("/arm/position_reference", "/arm/position"):
        assert all(v is None or np.isfinite(v).all() for v in trace.outputs[topic])
    assert trace.outputs["/arm/position"][-1].tolist() == pytest.approx([0.0, 0.3, 0.6],
                                                                         abs=1e-3)


def test_a_state_that_turns_nan_violates_a_checked_tolerance_and_nothing_nan_is_written(
) -> None:
    # NaN compares false: unchecked, a NaN error would pass every tolerance (the goal
    # would "succeed" with the arm's state unknown)
    goal = _goal(_trajectory(JOINTS, (0.5, [1.0, 1.0])), path={"a": 0.05})
    specs = [rtcf.ComponentSpec("arm", GoesNan, params={"initial_positions": [0.0, 0.0],
                                                        "nan_s": 0.2}, is_first=True),
             rtcf.ComponentSpec("jtc", JointTrajectoryController, params={
                 "joints": JOINTS, "command_interfaces": ["position"],
                 "state_interfaces": ["position", "velocity"], **GOAL_TOLERANCE})]
    trace = run_components(specs, 80, frequency=HZ, actions={ACTION: {0: goal}})
    record = _goals(trace)[goal.id]
    assert record.states[-1] == (20, GoalStatus.ABORTED)
    assert record.result.error_code == Result.PATH_TOLERANCE_VIOLATED
    assert _all_finite(trace)  # the hold where the joints read NaN is never written
    assert trace.components["/jtc"].refused_samples == 59
