"""rtcf_controllers' controllers under a thousand generated messages per interface, sent
over ROS 2 from this process to a runner started as `rtcf launch ... --middleware ros2`
(issue 38, "Bad commands never reach the hardware"):

* the arm (arm.launch.xml ros2_controllers:=true, MuJoCo in real time):
  joint_trajectory_controller's ``/arm_controller/follow_joint_trajectory`` goals and
  its ``/arm_controller/joint_trajectory`` topic;
* the diffbot (diffbot.launch, MuJoCo): diff_drive_controller's ``cmd_vel``;
* fixtures/simple.launch.xml: forward_command_controller's ``~/commands`` and
  pid_controller's ``~/reference``.

The messages: well-formed ones, and ones with NaN, +-inf, huge, subnormal values, wrong
lengths, unknown or repeated joints, negative or non-increasing times, tolerances with
NaN. Each is judged here, as the controllers must: refused, accepted, or either (what a
controller may clamp or take: a huge finite speed, a NaN tolerance).

Checked per runner, each by a test of its own so that every failure shows:
* it stays up and its loop runs on after the fuzz (its ROS topics still come);
* every value its components wrote on a command port, as the run's MCAP recording
  (--record) holds them, is finite and within the limits (the arm's joint ranges from
  its MJCF model, its motors' range; the diffbot's wheel speeds that its controller's
  limits allow), and the arm's measured joints stay in their ranges; what the
  recording dropped it counted, and the MuJoCo hardware's own check of its command
  input (which sees every command: rtcf's add_command_input) refused none;
* MuJoCo never reported an instability (it writes MUJOCO_LOG.TXT in the process's
  working directory, a fresh one here, and nothing on the console);
* each goal is accepted or rejected as judged, and each rejected goal is named in
  exactly one log line ("goal N rejected: ..."; one naming the point and the joint
  when a value was the problem);
* each refused topic message is named: the refusal lines of the controller, plus the
  counts its throttled lines carry ("(N more like it since the last record)"), add up
  to the messages it read (the recording holds each message in the iteration it was
  read) that must be refused, up to those that may be.
"""

from __future__ import annotations

import math
import os
import re
import signal
import threading
import time
import xml.etree.ElementTree as ET
from itertools import pairwise, zip_longest
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance, MultiDOFCommand
from geometry_msgs.msg import TwistStamped
from hypothesis import Phase, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from ... import _proc
from ..._fuzz import (
    EXTREME,
    NOT_FINITE,
    THOUSAND,
    TINY,
    component_lines,
    refused_count,
)
from .._action_client import action_client
from ..conftest import rtcf_env
from ..test_topics import spin_until

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[3]
EXAMPLES = REPO / "src" / "rtcf_examples"
SIMPLE = Path(__file__).parent / "fixtures" / "simple.launch.xml"

# a thousand each, in a fixed order; a failure is reported as generated (shrinking would
# send thousands more to a runner that may be gone)
FUZZ = settings(THOUSAND, phases=[Phase.explicit, Phase.generate])
REFUSE, ACCEPT, EITHER = "refuse", "accept", "either"


def _model_ranges() -> dict[str, tuple[float, float]]:
    """The arm's joints and their ranges, from its MJCF model."""
    root = ET.parse(EXAMPLES / "models" / "arm.xml").getroot()
    return {j.get("name"): tuple(map(float, j.get("range").split()))
            for j in root.iter("joint") if j.get("name")}


LIMITS = _model_ranges()
JOINTS = tuple(LIMITS)  # joint1, joint2, joint3: the controller's joints
EFFORT_LIMIT = 60.0  # the motors' ctrlrange in arm.xml, JointImpedance's effort_limit
F32_EPS = float(np.finfo(np.float32).eps)  # ros2_controllers' "zero" end velocity


# -- the runner under fuzz ------------------------------------------------------------


class Run:
    """One `rtcf launch ... --middleware ros2 --record` in a directory of its own, its
    console read on as it runs (a full pipe would block it)."""

    def __init__(self, where: Path, *target: str, record_topics: str) -> None:
        self.where = where
        self.mcap = where / "run.mcap"
        env = rtcf_env()
        env["PYTHONPATH"] = os.pathsep.join([str(REPO), env["PYTHONPATH"]])  # tests.ros2...
        self.proc = _proc.start_rtcf(env, "launch", *target, "--middleware", "ros2",
                                     "--record", self.mcap, "--record-topics", record_topics,
                                     "--report", where / "report", cwd=where)
        self.lines: list[str] = []  # stderr: rtcf's lines and the components' log records
        self.out: list[str] = []  # stdout: the run's summary
        self.rec: Any = None
        self.returncode: int | None = None
        said = _proc.wait_running(self.proc, timeout=60)
        self.lines.extend(said.splitlines(keepends=True))
        _proc._SEEN.pop(self.proc.pid, None)
        self._readers = [threading.Thread(target=self._read, args=(f, into), daemon=True)
                         for f, into in ((self.proc.stderr, self.lines),
                                         (self.proc.stdout, self.out))]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(stream: Any, into: list[str]) -> None:
        into.extend(iter(stream.readline, ""))

    def alive(self) -> None:
        assert self.proc.poll() is None, "the runner ended:\n" + "".join(self.lines[-30:])

    def stopped(self) -> Run:
        """Ended by SIGINT (once), its console read to the end and its recording read."""
        if self.returncode is None:
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGINT)
            try:
                self.returncode = self.proc.wait(timeout=60)
            except Exception:
                self.proc.kill()
                self.returncode = self.proc.wait()
            for reader in self._readers:
                reader.join(timeout=10)
            for pipe in (self.proc.stdout, self.proc.stderr):
                pipe.close()  # read to the end: else a ResourceWarning at teardown
            import rtcf.recording

            self.rec = rtcf.recording.read(str(self.mcap))
        return self

    def log(self, component: str) -> list[str]:
        return component_lines([x.rstrip("\n") for x in self.lines], component)

    def values(self, topic: str) -> np.ndarray:
        """Every recorded value of a float-array topic (a row per write)."""
        assert topic in self.rec.topics, (topic, self.rec.topics)
        return np.asarray(self.rec.series(topic).values, dtype=float)

    def read_messages(self, topic: str) -> list[Any]:
        """The messages a mapped input's components read, decoded, in order."""
        decode = self.rec.decoder(topic)
        return [decode(m.data) for m in self.rec.messages.get(topic, [])]

    def check_no_instability(self) -> None:
        said = "".join(self.lines + self.out)
        assert not re.search(r"Nan, Inf or huge value|unstable", said), said[-3000:]
        log = self.where / "MUJOCO_LOG.TXT"
        assert not log.exists(), log.read_text()[-3000:]

    def check_every_command_accounted(self, topics: list[str],
                                      hardware_inputs: list[str] = ()) -> None:
        """What the recording could not hold it counted (its ring full while the fuzz
        starved the supervisor: said, not hidden); and each hardware command input's
        own check, which sees every command (none dropped), refused none: the
        controllers never wrote a value that is not finite to the hardware."""
        import json

        dropped = json.loads(self.rec.metadata.get("dropped", "{}") or "{}")
        recorded = {t: len(self.rec.messages.get(t, [])) for t in topics}
        lost = {t: n for t, n in dropped.items() if t in topics and n}
        print(f"\nrecorded {recorded}, dropped (counted) {lost}")
        assert all(recorded.values()), recorded
        limits = json.loads((self.where / "report" / "timing.json").read_text()).get(
            "command_limits", {})
        for name in hardware_inputs:
            checked = limits[name]
            refused = {k: v for k, v in checked.items() if k.startswith("refused_") and v}
            assert not refused, f"{name} refused commands: {refused}"

    def end(self) -> None:
        if self.returncode is None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
            for reader in self._readers:
                reader.join(timeout=10)
            for pipe in (self.proc.stdout, self.proc.stderr):
                pipe.close()


class Topic:
    """A topic fuzzed: what was sent (with this test's verdict on each)."""

    def __init__(self, node: Any, msg_type: type, name: str, period: float,
                 judge: Any) -> None:
        self.pub = node.create_publisher(msg_type, name, 100)
        self.name = name
        self.judge = judge
        self.period = period  # about the reading component's: a message per run
        self.sent: list[str] = []
        self._due = 0.0

    def send(self, message: Any, verdict: str) -> None:
        now = time.monotonic()
        if now < self._due:
            time.sleep(self._due - now)
        self.pub.publish(message)
        self.sent.append(verdict)
        self._due = time.monotonic() + self.period


def flush(*pairs: tuple[Topic, list[Any]]) -> None:
    """After the fuzz, one refused message of each kind per topic, each more than the
    throttling interval after the one before: a controller may throttle each kind of
    problem on its own (rtcf_controllers' Throttled: the count of those left out rides
    on the next record of that kind), so each kind's count comes out."""
    for topic, messages in pairs:
        assert all(topic.judge(m)[0] == REFUSE for m in messages)
    for round_ in zip_longest(*(messages for _, messages in pairs)):
        time.sleep(1.2)
        for (topic, _), message in zip(pairs, round_, strict=True):
            if message is not None:
                topic.send(message, REFUSE)
    time.sleep(0.5)


def check_topic_refusals(run: Run, topic: Topic, component: str, judge: Any,
                         lines: list[str], period: float = 0.001) -> None:
    """The refusals named in ``lines`` against the messages the controller read (those
    the recording holds; any it dropped may have been either)."""
    import json

    read = run.read_messages(topic.name)
    lost = json.loads(run.rec.metadata.get("dropped", "{}") or "{}").get(topic.name, 0)
    assert len(topic.sent) >= 1000
    # each message was read, or superseded by a newer one before an iteration read it:
    # on a loaded machine DDS hands them over in bursts, of which the loop reads the last,
    # so what counts is that many were read (not which share)
    assert len(read) + lost >= 200, (len(read), lost, len(topic.sent))
    verdicts = [judge(m)[0] for m in read]
    must, may = verdicts.count(REFUSE), verdicts.count(EITHER)
    # a controller slower than the loop (its ``period``) may never see a message that
    # the loop took in and the next one replaced before the controller's next run
    times = [m.log_time for m in run.rec.messages.get(topic.name, [])]
    replaced = [k for k, (a, b) in enumerate(pairwise(times)) if (b - a) * 1e-9 < period]
    unseen = len(replaced)
    must -= sum(verdicts[k] == REFUSE for k in replaced)
    assert must >= 100, verdicts  # many of the fuzz's malformed messages were read
    named = refused_count(lines)
    assert must <= named <= must + may + lost + unseen, (
        f"{component}: {named} refusals named (lines and their counts) for {len(read)} "
        f"messages read and recorded, {must} of which must be refused and {may} may be, "
        f"and {lost} read and not recorded (the recording's ring full); {len(lines)} "
        f"lines, the first: {lines[:5]}")


REFUSAL = re.compile(r"refus|reject|ignor|not finite|non-finite|holds nan", re.I)
GOAL_LINE = re.compile(r"\bgoal (\d+)\b")


def refusal_lines(run: Run, component: str, topic: str) -> list[str]:
    """The component's lines that name refused input on ``topic`` (a word of its name:
    not its goals' lines, nor those of its state inputs)."""
    return [t for t in run.log(component) if REFUSAL.search(t) and topic in t
            and not GOAL_LINE.search(t) and "timed out" not in t
            and "not written" not in t]  # its own output refused, not its input


@pytest.fixture(scope="module")
def node():
    import rclpy
    from rclpy.node import Node

    context = rclpy.Context()
    rclpy.init(context=context)
    made = []

    def new(name: str) -> Any:
        made.append(Node(f"rtcf_fuzz_{name}_{os.getpid()}", context=context))
        return made[-1]

    try:
        yield new
    finally:
        for n in made:
            n.destroy_node()
        rclpy.shutdown(context=context)


# -- joint_trajectory_controller: goals and trajectories --------------------------------


def _duration(seconds: float) -> Duration:
    sec = math.floor(seconds)
    return Duration(sec=sec, nanosec=min(round((seconds - sec) * 1e9), 999_999_999))


def _seconds(d: Any) -> float:
    return d.sec + d.nanosec * 1e-9


def judge_trajectory(traj: Any) -> tuple[str, str]:
    """Whether the arm's controller must refuse ``traj`` (a JointTrajectory, stamp 0),
    must accept it, or may do either; and why."""
    names = list(traj.joint_names)
    if sorted(names) != sorted(JOINTS):
        return REFUSE, "joints"
    points = list(traj.points)
    if not points:
        return REFUSE, "no points"
    verdict, previous = ACCEPT, None
    for i, p in enumerate(points):
        t = _seconds(p.time_from_start)
        if t < 0 or (previous is not None and t <= previous):
            return REFUSE, f"time of point {i}"
        previous = t
        if len(p.positions) != 3 or len(p.velocities) not in (0, 3) or len(
                p.accelerations) not in (0, 3):
            return REFUSE, f"lengths of point {i}"
        if len(p.effort):
            return REFUSE, "effort (no effort interface)"
    for i, p in enumerate(points):
        for field in ("positions", "velocities", "accelerations"):
            for name, v in zip(names, getattr(p, field), strict=False):
                if not math.isfinite(v):
                    return REFUSE, f"value: point {i} {field} {name} {v}"
        for name, v in zip(names, p.positions, strict=True):
            lo, hi = LIMITS[name]
            if not lo <= v <= hi:
                return REFUSE, f"value: point {i} positions {name} {v} beyond [{lo}, {hi}]"
        for v in [*p.velocities, *p.accelerations]:
            if abs(v) > 1e-300:
                verdict = EITHER  # a spline through it may leave the limits: clamped or refused
    if any(abs(v) > F32_EPS for v in points[-1].velocities):
        return REFUSE, "nonzero velocity at the end"
    return verdict, ""


def judge_goal(goal: Any) -> tuple[str, str]:
    verdict, why = judge_trajectory(goal.trajectory)
    if verdict == ACCEPT:
        tolerances = [*goal.path_tolerance, *goal.goal_tolerance]
        numbers = [x for t in tolerances for x in (t.position, t.velocity, t.acceleration)]
        if (any(not (math.isfinite(x) and x >= 0) for x in numbers)
                or any(t.name not in JOINTS for t in tolerances)
                or _seconds(goal.goal_time_tolerance) < 0):
            return EITHER, "tolerances"
    return verdict, why


def _inside(joint: str) -> st.SearchStrategy[float]:
    lo, hi = LIMITS[joint]
    return st.one_of(st.floats(0.8 * lo, 0.8 * hi), st.sampled_from((*TINY, 0.0, -0.0)))


def _beyond(joint: str) -> st.SearchStrategy[float]:
    lo, hi = LIMITS[joint]
    return st.one_of(EXTREME.filter(lambda v: not math.isfinite(v) or abs(v) > hi),
                     st.sampled_from([lo - 0.01, hi + 0.01, lo - 1.0, hi + 5.0]))


@st.composite
def trajectories(draw: Any) -> JointTrajectory:
    """Mostly the controller's joints with in-range points, then 0-3 corruptions."""
    names = list(draw(st.one_of(
        st.permutations(JOINTS), st.permutations(JOINTS), st.permutations(JOINTS),
        st.lists(st.sampled_from((*JOINTS, "elbow", "")), max_size=4))))
    n = draw(st.sampled_from([1, 1, 2, 2, 3, 4, 0]))
    t, points = 0.0, []
    for _ in range(n):
        t += draw(st.floats(0.05, 0.6))
        points.append(JointTrajectoryPoint(
            positions=[draw(_inside(j)) if j in LIMITS else 0.0 for j in names],
            time_from_start=_duration(t)))
    for field in ("velocities", "accelerations"):
        if points and draw(st.booleans()):
            for p in points:
                setattr(p, field, [0.0] * len(names))
    for _ in range(draw(st.sampled_from([0, 0, 1, 1, 1, 2, 3]))):
        if points:
            _corrupt(draw, names, points)
    return JointTrajectory(joint_names=names, points=points)


def _corrupt(draw: Any, names: list[str], points: list[JointTrajectoryPoint]) -> None:
    kind = draw(st.sampled_from(["value", "value", "value", "length", "time", "effort",
                                 "end velocity"]))
    i = draw(st.integers(0, len(points) - 1))
    p = points[i]
    if kind == "value" and names:
        field = draw(st.sampled_from(["positions", "positions", "velocities", "accelerations"]))
        values = list(getattr(p, field)) or [0.0] * len(names)
        k = draw(st.integers(0, len(values) - 1))
        joint = names[k] if k < len(names) and names[k] in LIMITS else "joint1"
        values[k] = draw(_beyond(joint) if field == "positions" else EXTREME)
        setattr(p, field, values)
    elif kind == "length":
        field = draw(st.sampled_from(["positions", "velocities", "accelerations"]))
        setattr(p, field, draw(st.lists(st.one_of(EXTREME, st.floats(-1, 1)), max_size=5)))
    elif kind == "time":
        if i == 0 or draw(st.booleans()):
            p.time_from_start = Duration(sec=draw(st.sampled_from([-1, -5, -2**31])),
                                         nanosec=draw(st.integers(0, 999_999_999)))
        else:
            p.time_from_start = points[i - 1].time_from_start  # not increasing
    elif kind == "effort":
        p.effort = draw(st.lists(st.one_of(EXTREME, st.floats(-10, 10)), min_size=1,
                                 max_size=4))
    else:  # the last point still moving: finite, or not
        points[-1].velocities = [draw(st.one_of(st.floats(-2, 2), EXTREME)) for _ in names]


TOLERANCE_NUMBERS = st.one_of(st.floats(0, 1), EXTREME, st.just(-1.0))


@st.composite
def goals(draw: Any) -> FollowJointTrajectory.Goal:
    goal = FollowJointTrajectory.Goal(trajectory=draw(trajectories()))
    if draw(st.integers(0, 4)) == 0:
        for field in ("path_tolerance", "goal_tolerance"):
            setattr(goal, field, [
                JointTolerance(name=draw(st.sampled_from((*JOINTS, "elbow"))),
                               position=draw(TOLERANCE_NUMBERS),
                               velocity=draw(TOLERANCE_NUMBERS),
                               acceleration=draw(TOLERANCE_NUMBERS))
                for _ in range(draw(st.integers(0, 3)))])
        goal.goal_time_tolerance = Duration(sec=draw(st.sampled_from([0, 1, -1])))
    return goal


ARM_COMMANDS = ["/arm/position_reference", "/arm/velocity_reference", "/arm/effort_command"]
ARM_TRAJECTORY = "/arm_controller/joint_trajectory"


class Arm:
    def __init__(self, run: Run, ros: Any) -> None:
        self.run, self.node = run, ros
        self.goals: list[tuple[str, str, bool]] = []  # verdict, why, accepted (sent order)
        self.client: Any = None
        self.topic = Topic(ros, JointTrajectory, ARM_TRAJECTORY, period=0.008,
                           judge=judge_trajectory)
        self.states: list[JointState] = []
        self.pending: list[tuple[int, Any, bool]] = []  # goal, its future, cancel it
        self.cancels: list[Any] = []

    def settle(self, in_flight: int) -> bool:
        """Spin until at most ``in_flight`` goals wait for their answer (10 s at most);
        note each answer and cancel the accepted goals that are to be canceled."""

        def answered() -> bool:
            waiting = []
            for k, future, cancel in self.pending:
                if not future.done():
                    waiting.append((k, future, cancel))
                    continue
                handle = future.result()
                verdict, why, _ = self.goals[k]
                self.goals[k] = (verdict, why, handle.accepted)
                if handle.accepted and cancel:
                    self.cancels.append(handle.cancel_goal_async())
            self.pending = waiting
            return len(waiting) <= in_flight

        return self.client.until(answered, timeout=10)


@pytest.fixture(scope="module")
def arm(node, tmp_path_factory):
    run = Run(tmp_path_factory.mktemp("arm"), "rtcf_examples", "arm.launch.xml",
              "ros2_controllers:=true",
              record_topics=f"/arm/(position_reference|velocity_reference|effort_command)|"
                            f"{ARM_TRAJECTORY}")
    state = Arm(run, node("arm"))
    # the joints as measured, while the fuzz's goals run (at 100 Hz: recording them at
    # the loop's 1 kHz too would take the supervisor's time that the commands need)
    state.node.create_subscription(JointState, "/joint_states", state.states.append, 1000)
    try:
        with action_client(state.node, FollowJointTrajectory,
                           "/arm_controller/follow_joint_trajectory") as client:
            state.client = client
            yield state
    finally:
        run.end()


IN_FLIGHT = 4  # goals sent and not yet answered, at most (the runner queues more)


@FUZZ
@given(goal=goals(), cancel=st.integers(0, 3))
def test_arm_a_thousand_generated_goals_are_each_answered(arm, goal, cancel):
    """Sent without waiting for each answer (a few in flight, in order: the runner
    numbers them as they come); a quarter of the accepted ones canceled, the rest
    preempted by the next."""
    arm.run.alive()
    arm.pending.append((len(arm.goals), arm.client.send_goal_async(goal), cancel == 0))
    arm.goals.append((*judge_goal(goal), None))
    assert arm.settle(IN_FLIGHT), "goals not answered in 10 s"


def test_arm_every_goal_was_answered(arm):
    assert arm.settle(0), "goals not answered in 10 s"
    assert len(arm.goals) >= 1000


@FUZZ
@given(trajectory=trajectories())
def test_arm_a_thousand_generated_trajectories_on_its_topic(arm, trajectory):
    arm.run.alive()
    arm.topic.send(trajectory, judge_trajectory(trajectory)[0])


def test_arm_runs_on_after_the_fuzz(arm):
    def trajectory(names=JOINTS, **point: Any) -> JointTrajectory:
        fields = {"positions": [0.0, 0.3, 0.6], "time_from_start": Duration(sec=1), **point}
        return JointTrajectory(joint_names=list(names), points=[JointTrajectoryPoint(**fields)])

    flush((arm.topic, [
        trajectory(positions=[math.nan, 0.3, 0.6]),  # not finite
        trajectory(positions=[0.0, 1e300, 0.6]),  # beyond a limit
        trajectory(velocities=[0.0, math.inf, 0.0]),
        trajectory(names=["joint1", "elbow", "joint3"]),
        trajectory(names=["joint1", "joint2"]),
        JointTrajectory(joint_names=list(JOINTS)),  # no points
        trajectory(positions=[0.0, 0.3]),  # lengths
        trajectory(effort=[0.0, 0.0, 0.0]),
        trajectory(time_from_start=Duration(sec=-1)),
        trajectory(velocities=[0.5, 0.0, 0.0]),  # moving at the end
    ]))
    before = len(arm.states)
    assert arm.client.until(lambda: len(arm.states) >= before + 20, timeout=15), (
        "no /joint_states after the fuzz")
    arm.run.alive()


def test_arm_measured_joints_stay_finite_and_within_their_ranges(arm):
    positions = np.array([s.position for s in arm.states])
    # joint_state_broadcaster says NaN for a joint with no value yet (ros2_controllers'
    # convention): its lane may publish once before the hardware's first measurement
    while len(positions) and np.isnan(positions[0]).all():
        positions = positions[1:]
    assert len(positions) > 100
    lo = np.array([LIMITS[j][0] for j in JOINTS])
    hi = np.array([LIMITS[j][1] for j in JOINTS])
    # MuJoCo's joint limits are soft: a joint pushed into its limit goes a little beyond
    bad = ~np.isfinite(positions).all(axis=1) | (
        (positions < lo - 0.05) | (positions > hi + 0.05)).any(axis=1)
    assert not bad.any(), (int(bad.sum()), len(positions), positions[bad][:5].tolist())


def test_arm_goals_are_accepted_or_rejected_as_judged(arm):
    goals = arm.goals
    assert len(goals) >= 1000
    said = {int(m[1]): t for t in arm.run.stopped().log("/arm_controller")
            if (m := GOAL_LINE.search(t)) and "rejected" in t}
    # a goal whose points are within the limits may still be refused because its first
    # spline, from where the arm is (which this judge does not know), swings out of them
    swings = {k + 1 for k, (verdict, _, accepted) in enumerate(goals)
              if verdict == ACCEPT and not accepted
              and "its spline to point 0 takes" in said.get(k + 1, "")}
    wrong = [(k + 1, verdict, why) for k, (verdict, why, accepted) in enumerate(goals)
             if (verdict == REFUSE and accepted)
             or (verdict == ACCEPT and not accepted and k + 1 not in swings)]
    counts = {v: sum(1 for g in goals if g[0] == v) for v in (REFUSE, ACCEPT, EITHER)}
    assert counts[ACCEPT] >= 100 and counts[REFUSE] >= 300, counts
    assert len(swings) <= 0.1 * counts[ACCEPT], sorted(swings)
    assert not wrong, (f"{len(wrong)} of {len(goals)} goals answered against their "
                       f"verdict ({counts}); the first (goal, verdict, why, what the "
                       f"controller said): {[(*w, said.get(w[0])) for w in wrong[:15]]}")


def test_arm_each_rejected_goal_is_named_in_one_line(arm):
    run = arm.run.stopped()
    lines = {}  # goal id: its lines that say it was rejected
    for text in run.log("/arm_controller"):
        found = GOAL_LINE.search(text)
        if found and "rejected" in text:
            lines.setdefault(int(found.group(1)), []).append(text)
    # the runner numbers the goals from 1 as they come: the fuzz's, in the order sent
    rejected = {k + 1 for k, (_, _, accepted) in enumerate(arm.goals) if accepted is False}
    unnamed = sorted(rejected - set(lines))
    twice = {k: v for k, v in lines.items() if len(v) > 1}
    stray = {k: v for k, v in lines.items() if k not in rejected}
    assert not (unnamed or twice or stray), (
        f"{len(rejected)} goals rejected; without a line: {len(unnamed)} {unnamed[:20]}; "
        f"named twice: {list(twice.items())[:3]}; lines of goals not rejected: "
        f"{list(stray.items())[:3]}")
    vague = [lines[k + 1][0] for k, (_, why, accepted) in enumerate(arm.goals)
             if accepted is False and why.startswith("value")
             and not ("point" in lines[k + 1][0] and any(j in lines[k + 1][0] for j in JOINTS))]
    assert not vague, f"{len(vague)} lines that name no point and joint: {vague[:10]}"


def test_arm_each_refused_trajectory_on_its_topic_is_named(arm):
    run = arm.run.stopped()
    check_topic_refusals(run, arm.topic, "/arm_controller", judge_trajectory,
                         refusal_lines(run, "/arm_controller", "joint_trajectory"),
                         period=0.004)  # arm.launch's trajectory_rate, 250 Hz


def test_arm_commands_stay_finite_and_within_the_limits(arm):
    run = arm.run.stopped()
    lo = np.array([LIMITS[j][0] for j in JOINTS])
    hi = np.array([LIMITS[j][1] for j in JOINTS])
    problems = {}
    for topic in ARM_COMMANDS:
        values = run.values(topic)
        assert values.ndim == 2 and values.shape[1] == 3 and len(values) > 1000, values.shape
        bad = ~np.isfinite(values).all(axis=1)
        if topic == "/arm/position_reference":
            bad |= ((values < lo) | (values > hi)).any(axis=1)
        elif topic == "/arm/effort_command":
            bad |= (np.abs(values) > EFFORT_LIMIT).any(axis=1)
        if bad.any():
            problems[topic] = (int(bad.sum()), len(values), values[bad][:3].tolist())
    assert not problems, f"(values beyond, of, the first): {problems}"


def test_arm_mujoco_never_reports_an_instability(arm):
    arm.run.stopped().check_no_instability()


def test_arm_every_command_is_accounted_for(arm):
    arm.run.stopped().check_every_command_accounted(
        ARM_COMMANDS, ["/arm/hardware.effort_command"])


def test_arm_runner_ended_cleanly(arm):
    run = arm.run.stopped()
    assert run.returncode == 0, "".join(run.lines[-30:])
    assert not [x for x in run.lines if "Traceback" in x], "".join(run.lines[-60:])


# -- diff_drive_controller's cmd_vel ---------------------------------------------------

# diffbot_controllers.yaml: |linear.x| <= 1 m/s, |angular.z| <= 2 rad/s, wheels of
# 0.05 m radius 0.30 m apart: no wheel turns faster than (1 + 2 * 0.15) / 0.05 rad/s
WHEEL_LIMIT = (1.0 + 2.0 * 0.30 / 2) / 0.05
CMD_VEL = "/diffbot_base_controller/cmd_vel"


def judge_twist(message: Any) -> tuple[str, str]:
    t = message.twist
    used = (t.linear.x, t.angular.z)
    rest = (t.linear.y, t.linear.z, t.angular.x, t.angular.y)
    if not all(map(math.isfinite, used)):
        return REFUSE, "not finite"
    if all(map(math.isfinite, rest)) and abs(used[0]) <= 1.0 and abs(used[1]) <= 2.0 and all(
            abs(x) < 1e6 for x in rest):
        return ACCEPT, ""
    return EITHER, "beyond its limits, or a field it does not use not finite"


TWIST_NUMBERS = st.one_of(NOT_FINITE, NOT_FINITE, EXTREME, st.floats(-1.0, 1.0),
                          st.floats(-1e6, 1e6))


@st.composite
def twists(draw: Any) -> TwistStamped:
    message = TwistStamped()  # stamp 0: now
    t = message.twist
    fields = [(t.linear, "x"), (t.linear, "y"), (t.linear, "z"),
              (t.angular, "x"), (t.angular, "y"), (t.angular, "z")]
    for owner, name in fields:
        setattr(owner, name, draw(st.floats(-0.5, 0.5) if name in "xz" and owner is t.linear
                                  else st.floats(-1.0, 1.0)))
    used = [(t.linear, "x"), (t.angular, "z")]  # what the controller reads: most often
    for _ in range(draw(st.sampled_from([0, 1, 1, 2]))):  # a quarter well-formed
        owner, name = draw(st.sampled_from([*used, *used, *fields]))
        setattr(owner, name, draw(TWIST_NUMBERS))
    return message


class Diffbot:
    def __init__(self, run: Run, ros: Any) -> None:
        self.run, self.node = run, ros
        self.topic = Topic(ros, TwistStamped, CMD_VEL, period=0.004, judge=judge_twist)


@pytest.fixture(scope="module")
def diffbot(node, tmp_path_factory):
    run = Run(tmp_path_factory.mktemp("diffbot"), "rtcf_examples", "diffbot.launch",
              record_topics=f"/velocity_command|{CMD_VEL}")
    try:
        yield Diffbot(run, node("diffbot"))
    finally:
        run.end()


@FUZZ
@given(message=twists())
def test_diffbot_a_thousand_generated_cmd_vel(diffbot, message):
    diffbot.run.alive()
    diffbot.topic.send(message, judge_twist(message)[0])


def test_diffbot_runs_on_after_the_fuzz(diffbot):
    bad = [TwistStamped(), TwistStamped(), TwistStamped()]
    bad[0].twist.linear.x = math.nan
    bad[1].twist.angular.z = math.inf
    bad[2].twist.linear.x = -math.inf
    flush((diffbot.topic, bad))
    odoms: list[Odometry] = []
    diffbot.node.create_subscription(Odometry, "/diffbot_base_controller/odom",
                                     odoms.append, 100)
    assert spin_until(diffbot.node, lambda: len(odoms) >= 10, timeout=15), "no odom"
    diffbot.run.alive()


def test_diffbot_each_refused_cmd_vel_is_named(diffbot):
    run = diffbot.run.stopped()
    check_topic_refusals(run, diffbot.topic, "/diffbot_base_controller", judge_twist,
                         refusal_lines(run, "/diffbot_base_controller", "cmd_vel"))


def test_diffbot_wheel_commands_stay_finite_and_within_the_limits(diffbot):
    run = diffbot.run.stopped()
    values = run.values("/velocity_command")
    assert len(values) > 1000, values.shape
    bad = ~np.isfinite(values).all(axis=1) | (np.abs(values) > WHEEL_LIMIT + 1e-9).any(axis=1)
    assert not bad.any(), (int(bad.sum()), len(values), values[bad][:5].tolist())


def test_diffbot_mujoco_never_reports_an_instability(diffbot):
    diffbot.run.stopped().check_no_instability()


def test_diffbot_every_command_is_accounted_for(diffbot):
    diffbot.run.stopped().check_every_command_accounted(
        ["/velocity_command"], ["/diffbot.velocity_command"])


def test_diffbot_runner_ended_cleanly(diffbot):
    run = diffbot.run.stopped()
    assert run.returncode == 0, "".join(run.lines[-30:])
    assert not [x for x in run.lines if "Traceback" in x], "".join(run.lines[-60:])


# -- forward_command_controller and pid_controller (fixtures/simple.launch.xml) -------

FORWARD = "/forward_position_controller/commands"
REFERENCE = "/wheel_pid_controller/reference"
SIMPLE_COMMANDS = ["/arm/position_command", "/wheel/effort_command"]


def judge_commands(message: Any) -> tuple[str, str]:
    data = list(message.data)
    if len(data) != 3 or not all(map(math.isfinite, data)):
        return REFUSE, "length or not finite"
    return (ACCEPT, "") if all(abs(x) < 1e6 for x in data) else (EITHER, "huge")


def judge_reference(message: Any) -> tuple[str, str]:
    names, values, dots = list(message.dof_names), list(message.values), list(
        message.values_dot)
    if len(values) != 1 or len(names) > 1 or len(dots) > 1:
        return REFUSE, "lengths"
    if names and names[0] != "wheel_joint":
        return REFUSE, "unknown dof"
    if any(math.isinf(x) for x in values + dots):
        return REFUSE, "infinite"
    if any(math.isnan(x) for x in values + dots):  # ros2_controllers: NaN leaves it as it was
        return EITHER, "NaN"
    return (ACCEPT, "") if all(abs(x) < 1e6 for x in values + dots) else (EITHER, "huge")


VALUES = st.one_of(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), EXTREME)


@st.composite
def commands(draw: Any) -> Float64MultiArray:
    n = draw(st.sampled_from([3, 3, 3, 3, 0, 1, 2, 4, 7]))
    return Float64MultiArray(data=[draw(VALUES) for _ in range(n)])


@st.composite
def references(draw: Any) -> MultiDOFCommand:
    names = draw(st.sampled_from([["wheel_joint"], ["wheel_joint"], [], ["other"],
                                  ["wheel_joint", "wheel_joint"]]))
    values = [draw(VALUES) for _ in range(draw(st.sampled_from([1, 1, 1, 0, 2])))]
    dots = [draw(VALUES) for _ in range(draw(st.sampled_from([0, 1, 1, 2])))]
    return MultiDOFCommand(dof_names=names, values=values, values_dot=dots)


class Simple:
    def __init__(self, run: Run, ros: Any) -> None:
        self.run, self.node = run, ros
        self.forward = Topic(ros, Float64MultiArray, FORWARD, period=0.002,
                             judge=judge_commands)
        self.reference = Topic(ros, MultiDOFCommand, REFERENCE, period=0.002,
                               judge=judge_reference)


@pytest.fixture(scope="module")
def simple(node, tmp_path_factory):
    run = Run(tmp_path_factory.mktemp("simple"), SIMPLE,
              f"ros_topics:={FORWARD}|{REFERENCE}|/joint_states",
              record_topics="|".join([*SIMPLE_COMMANDS, FORWARD, REFERENCE]))
    try:
        yield Simple(run, node("simple"))
    finally:
        run.end()


@FUZZ
@given(message=commands())
def test_forward_command_controller_a_thousand_generated_commands(simple, message):
    simple.run.alive()
    simple.forward.send(message, judge_commands(message)[0])


@FUZZ
@given(message=references())
def test_pid_controller_a_thousand_generated_references(simple, message):
    simple.run.alive()
    simple.reference.send(message, judge_reference(message)[0])


def test_simple_runs_on_after_the_fuzz(simple):
    flush((simple.forward, [Float64MultiArray(data=[math.nan] * 3),
                            Float64MultiArray(data=[1.0, 2.0]),
                            Float64MultiArray(data=[0.0, math.inf, 0.0])]),
          (simple.reference, [MultiDOFCommand(dof_names=["wheel_joint"], values=[math.inf]),
                              MultiDOFCommand(dof_names=["other"], values=[1.0]),
                              MultiDOFCommand(dof_names=["wheel_joint"], values=[1.0, 2.0]),
                              MultiDOFCommand(values=[-math.inf])]))
    states: list[JointState] = []
    simple.node.create_subscription(JointState, "/joint_states", states.append, 100)
    assert spin_until(simple.node, lambda: len(states) >= 10, timeout=15), "no /joint_states"
    simple.run.alive()


def test_forward_command_controller_names_each_refused_command(simple):
    run = simple.run.stopped()
    check_topic_refusals(run, simple.forward, "/forward_position_controller", judge_commands,
                         refusal_lines(run, "/forward_position_controller", "commands"))


def test_pid_controller_names_each_refused_reference(simple):
    run = simple.run.stopped()
    check_topic_refusals(run, simple.reference, "/wheel_pid_controller", judge_reference,
                         refusal_lines(run, "/wheel_pid_controller", "reference"))


def test_simple_commands_stay_finite(simple):
    run = simple.run.stopped()
    problems = {}
    for topic in SIMPLE_COMMANDS:
        values = run.values(topic)  # the PID writes nothing while its state is not finite
        assert len(values), topic
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():
            problems[topic] = (int(bad.sum()), len(values), values[bad][:3].tolist())
    assert not problems, f"(values not finite, of, the first): {problems}"


def test_simple_every_command_is_accounted_for(simple):
    simple.run.stopped().check_every_command_accounted(SIMPLE_COMMANDS)


def test_simple_runner_ended_cleanly(simple):
    run = simple.run.stopped()
    assert run.returncode == 0, "".join(run.lines[-30:])
    assert not [x for x in run.lines if "Traceback" in x], "".join(run.lines[-60:])

