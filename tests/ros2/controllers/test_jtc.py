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
    return Duration(sec=int(seconds), nanosec=round(seconds % 1 * 1e9))


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
