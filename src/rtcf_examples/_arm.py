"""An arm in the loop: a MuJoCo model where the hardware interface would be, and the
controllers a robotics team writes against it (docs/examples.md, "An arm in a physics
simulation").

Every port carries one float64 array with a value per joint, in the joints' order,
named as ros2_control's interfaces are: ``position``, ``velocity`` and ``effort``
(state), ``effort_command`` (command). The controllers know nothing of MuJoCo: a
driver of a real arm with the same ports takes MujocoArm's place (the launch file's
``hardware`` argument) and nothing else changes.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

import rtcf

from . import _mujoco

MODEL = "arm.xml"  # shipped in rtcf_examples/models


def shipped_model() -> str:
    """The path of the example's MJCF model (package data)."""
    return _mujoco.shipped_model(MODEL)


def _floats(value: Any, n: int, what: str) -> np.ndarray:
    """A parameter given as one number (every joint) or a list of n numbers."""
    array = np.array(value if isinstance(value, (list, tuple)) else [value] * n, dtype=float)
    if array.shape != (n,) or not np.all(np.isfinite(array)):
        raise rtcf.ConfigurationError(
            f"{what} is {value!r}: give one number or a list of {n} (one per joint)"
        )
    return array


class MujocoArm(rtcf.Component):
    """The hardware interface of a simulated arm: steps a MuJoCo model once per
    iteration, first in the loop (``is_first``).

    Reads ``effort_command`` (the motors' torques, N m; none yet: zero) and writes what
    it measured after the step: ``position`` [rad], ``velocity`` [rad/s], ``effort``
    [N m] (what the motors applied, within their range) and ``gravity`` [N m] (the
    torques that hold the arm still where it is, MuJoCo's bias forces at rest: a real
    arm's driver gives its own model's, as many do).

    ``~model`` is an MJCF file (default: the shipped three-joint arm). Its timestep
    must divide the component's period (1 ms at 1 kHz is one step per iteration);
    anything else is refused in ``configure`` with both numbers. ``~initial_positions``
    sets the joints before the first step. Needs the ``mujoco`` package
    (``pip install 'rtcf[mujoco]'``).
    """

    def configure(self) -> None:
        sim = _mujoco.load_simulation(self, MODEL)
        mujoco, model, path = sim.mujoco, sim.model, sim.path
        self.mujoco, self.model, self.data, self.steps = mujoco, model, sim.data, sim.steps
        if model.nu != model.nv or model.nq != model.nv:
            raise rtcf.ConfigurationError(
                f"~model {path}: MujocoArm drives arms of hinge or slide joints, one "
                f"motor each; this model has {model.nq} positions, {model.nv} velocities "
                f"and {model.nu} actuators"
            )
        n = model.nu
        self.joints = [model.joint(int(model.actuator_trnid[i, 0])).name for i in range(n)]
        initial = self.params.get("~initial_positions", [0.0] * n)
        self.data.qpos[:] = _floats(initial, n, "~initial_positions")
        mujoco.mj_forward(model, self.data)
        # the motors' torques, checked before each step: never a non-finite one, and
        # within the model's control range (launch files may narrow it: joint_limits)
        self.effort_command = self.add_command_input(
            "effort_command", "effort", self.joints,
            _mujoco.actuator_limits(model, range(n), "effort"))
        self.position = self.add_output("position", np.ndarray)
        self.velocity = self.add_output("velocity", np.ndarray)
        self.effort = self.add_output("effort", np.ndarray)
        self.gravity = self.add_output("gravity", np.ndarray)
        self.log.info(
            "%s: %d joints (%s), %d step(s) of %g ms per iteration",
            path, n, ", ".join(self.joints), self.steps, float(model.opt.timestep) * 1e3,
        )

    def update(self) -> None:
        data = self.data
        command = self.effort_command.read()
        if command is not None:
            data.ctrl[:] = command
        self.mujoco.mj_step(self.model, data, self.steps)
        self.position.write(data.qpos.copy())
        self.velocity.write(data.qvel.copy())
        self.effort.write(data.actuator_force.copy())
        # qfrc_bias at rest is gravity alone; with the arm moving it adds Coriolis
        # terms, which an impedance controller's damping takes care of
        self.gravity.write(data.qfrc_bias.copy())

    def safe_stop(self) -> bool:
        """Hold the arm where it is, as a real driver switches its drives to holding
        position (zero velocity) when its controller stops: each motor becomes a
        position servo about the position of this moment, with the torque that holds
        the arm there against gravity. Zero torque would let the arm fall.
        ``~hold_stiffness`` and ``~hold_damping`` are the servos' gains."""
        mujoco, model, data = self.mujoco, self.model, self.data
        kp = float(self.params.get("~hold_stiffness", 300.0))
        kv = float(self.params.get("~hold_damping", 30.0))
        moving = data.qvel.copy()
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)  # the bias forces at rest: gravity alone
        gravity = data.qfrc_bias.copy()
        data.qvel[:] = moving
        for i in range(model.nu):
            dof = model.jnt_dofadr[model.actuator_trnid[i, 0]]
            model.actuator_gaintype[i] = mujoco.mjtGain.mjGAIN_FIXED
            model.actuator_biastype[i] = mujoco.mjtBias.mjBIAS_AFFINE
            model.actuator_gainprm[i, 0] = kp
            model.actuator_biasprm[i, :3] = (gravity[dof], -kp, -kv)
            model.actuator_ctrllimited[i] = 0
            data.ctrl[i] = data.qpos[model.jnt_qposadr[model.actuator_trnid[i, 0]]]
        self.log.warning("safe stop: holding %s", np.round(data.qpos, 3).tolist())
        return True


class JointImpedance(rtcf.Component):
    """A joint-space impedance controller with gravity compensation, at the loop's rate:

    ``effort_command = stiffness (position_reference - position)
    + damping (velocity_reference - velocity) + gravity``, clamped to ``+-~effort_limit``.

    ``stiffness`` [N m/rad] and ``damping`` [N m s/rad] are tunable while it runs;
    ``~stiffness_scale``/``~damping_scale`` weigh them per joint. Without a reference
    yet, it holds the position it first measured.
    """

    def configure(self) -> None:
        self.position = self.add_input("position", np.ndarray)
        self.velocity = self.add_input("velocity", np.ndarray)
        self.gravity = self.add_input("gravity", np.ndarray)
        self.position_reference = self.add_input("position_reference", np.ndarray)
        self.velocity_reference = self.add_input("velocity_reference", np.ndarray)
        self.effort_command = self.add_output("effort_command", np.ndarray)
        self.stiffness = self.params.declare(
            "stiffness", 200.0, description="joint stiffness [N m/rad]", min=0.0)
        self.damping = self.params.declare(
            "damping", 20.0, description="joint damping [N m s/rad]", min=0.0)
        self.stiffness_scale = self.params.get("~stiffness_scale", 1.0)
        self.damping_scale = self.params.get("~damping_scale", 1.0)
        self.limit = float(self.params.get("~effort_limit", math.inf))
        self.hold: np.ndarray | None = None

    def start(self) -> None:
        self.hold = None

    def update(self) -> None:
        q = self.position.read()
        if q is None:
            return  # nothing measured yet: command nothing
        qd = self.velocity.read()
        reference = self.position_reference.read()
        if reference is None:
            if self.hold is None:
                self.hold = q.copy()
            reference = self.hold
        velocity_reference = self.velocity_reference.read()
        effort = self.stiffness.value * self.stiffness_scale * (reference - q)
        if qd is not None:
            target = 0.0 if velocity_reference is None else velocity_reference
            effort += self.damping.value * self.damping_scale * (target - qd)
        gravity = self.gravity.read()
        if gravity is not None:
            effort += gravity
        self.effort_command.write(np.clip(effort, -self.limit, self.limit))


class TrajectoryInterpolator(rtcf.Component):
    """Joint trajectories, sampled at its own rate (250 Hz in arm.launch): from where
    the arm is to each point in turn, each segment a quintic in time (zero velocity and
    acceleration at both ends).

    ``~waypoints`` lists the joint positions of every point one after the other
    (``~joints`` numbers each, as ROS parameters take flat lists), ``~segment_s`` is
    each segment's duration, and ``~repeat`` starts over after the last.

    With ``~accept_trajectories``, it also reads ``joint_trajectory``, a
    ``trajectory_msgs/JointTrajectory`` (what ros2_control's joint_trajectory_controller
    takes on ``/arm_controller/joint_trajectory``): a new one replaces the plan when it
    arrives, from the reference of the moment through its points at their
    ``time_from_start``, then holds the last. Its ``joint_names`` may come in any order
    but must be ``~joint_names``; a trajectory that is not followable is logged and
    ignored, and the plan goes on.

    Writes ``position_reference`` and ``velocity_reference``; reads ``position`` for
    where to start. ``~fail_after_s`` raises in ``update`` after that time: a fault to
    try the launch file's fault policy with (arm.launch's HoldPosition takes over).
    """

    def configure(self) -> None:
        self.position = self.add_input("position", np.ndarray)
        self.position_reference = self.add_output("position_reference", np.ndarray)
        self.velocity_reference = self.add_output("velocity_reference", np.ndarray)
        flat = [float(x) for x in self.params.get("~waypoints", [])]
        self.n = int(self.params.get("~joints", 3))
        if not flat or len(flat) % self.n:
            raise rtcf.ConfigurationError(
                f"~waypoints has {len(flat)} numbers: give {self.n} per waypoint (~joints)"
            )
        self.waypoints = np.array(flat).reshape(-1, self.n)
        self.segment_s = float(self.params.get("~segment_s", 1.0))
        if not self.segment_s > 0:
            raise rtcf.ConfigurationError(f"~segment_s is {self.segment_s}: give seconds > 0")
        self.repeat = bool(self.params.get("~repeat", True))
        self.fail_after_s = float(self.params.get("~fail_after_s", math.inf))
        self.joint_names = [str(x) for x in self.params.get(
            "~joint_names", [f"joint{k + 1}" for k in range(self.n)])]
        if len(self.joint_names) != self.n:
            raise rtcf.ConfigurationError(
                f"~joint_names has {len(self.joint_names)} names for {self.n} joints")
        self.trajectory = None
        if self.params.get("~accept_trajectories", False):
            try:
                from trajectory_msgs.msg import JointTrajectory
            except ImportError:
                raise rtcf.ConfigurationError(
                    "~accept_trajectories needs trajectory_msgs (ROS 2: pip install "
                    "'rtcf[ros2]'; ROS 1: apt install python3-trajectory-msgs)"
                ) from None
            self.trajectory = self.add_input("joint_trajectory", JointTrajectory)
        self.refused_messages = {"joint_trajectory": 0}  # for tests and reports
        self.plan: _Plan | None = None
        self.reference: np.ndarray | None = None

    def start(self) -> None:
        self.plan = None

    def update(self) -> None:
        t = self.time
        if t >= self.fail_after_s:
            raise RuntimeError(f"failing at t={t:.3f} s, as ~fail_after_s asks")
        if self.plan is None:
            q = self.position.read()
            if q is None:
                return
            ends = self.segment_s * np.arange(1, len(self.waypoints) + 1)
            self.plan = _Plan(t, q.copy(), self.waypoints, ends, self.repeat)
        if self.trajectory is not None and self.trajectory.has_new_data:
            self._follow(self.trajectory.read(), t)
        position, velocity = self.plan.sample(t)
        self.reference = position
        self.position_reference.write(position)
        self.velocity_reference.write(velocity)

    def _follow(self, message: Any, t: float) -> None:
        names = list(message.joint_names)
        problem = None
        if sorted(names) != sorted(self.joint_names):
            problem = f"its joint_names {names} are not {self.joint_names}"
        elif not message.points:
            problem = "it has no points"
        if problem is None:
            order = [names.index(j) for j in self.joint_names]
            goals, ends = [], []
            for i, point in enumerate(message.points):
                d = point.time_from_start
                ends.append(float(getattr(d, "sec", getattr(d, "secs", 0)))
                            + 1e-9 * float(getattr(d, "nanosec", getattr(d, "nsecs", 0))))
                if not (math.isfinite(ends[-1]) and ends[-1] >= 0.0):
                    problem = f"point {i} time_from_start is {ends[-1]!r} s (negative)"
                    break
                if len(point.positions) != len(names):
                    problem = f"a point has {len(point.positions)} positions for {len(names)}"
                    break
                goals.append([float(point.positions[k]) for k in order])
                bad = [k for k, x in enumerate(goals[-1]) if not math.isfinite(x)]
                if bad:  # the reference would carry it to the joints' controller
                    problem = (f"point {i} position of {self.joint_names[bad[0]]} is "
                               f"{goals[-1][bad[0]]!r} (not finite)")
                    break
            if problem is None and any(b <= a for a, b in itertools.pairwise([0.0, *ends])):
                problem = f"its time_from_start {ends} do not increase from 0"
        if problem is not None:
            self.refused_messages["joint_trajectory"] += 1
            self.log.error("joint_trajectory ignored: %s; the plan goes on", problem)
            return
        begin = self.reference if self.reference is not None else self.plan.begin
        self.plan = _Plan(t, begin.copy(), np.array(goals), np.array(ends), False)
        self.log.info("following a trajectory of %d points over %.2f s", len(goals), ends[-1])


class _Plan:
    """Quintic segments from ``begin`` through ``goals`` (one row each) ending at
    ``ends`` seconds after ``t0``; with ``repeat`` it goes round again from the last."""

    def __init__(
        self, t0: float, begin: np.ndarray, goals: np.ndarray, ends: np.ndarray, repeat: bool
    ) -> None:
        self.t0, self.begin, self.goals, self.ends, self.repeat = t0, begin, goals, ends, repeat

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        elapsed = t - self.t0
        total = float(self.ends[-1])
        first_round = True
        if self.repeat and elapsed >= total:
            first_round = False
            elapsed %= total
        elif elapsed >= total:
            return self.goals[-1].copy(), np.zeros(len(self.begin))
        k = int(np.searchsorted(self.ends, elapsed, side="right"))
        since = 0.0 if k == 0 else float(self.ends[k - 1])
        duration = float(self.ends[k]) - since
        if k > 0:
            begin = self.goals[k - 1]
        else:
            begin = self.begin if first_round else self.goals[-1]
        goal = self.goals[k]
        s = (elapsed - since) / duration
        shape = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
        rate = 30.0 * s * s * (1.0 - s) * (1.0 - s) / duration
        return begin + (goal - begin) * shape, (goal - begin) * rate


class JointStateBroadcaster(rtcf.Component):
    """``sensor_msgs/JointState`` from the joints' arrays, at its own rate (100 Hz in
    arm.launch), stamped with the iteration's time: what ros2_control's
    joint_state_broadcaster publishes on ``/joint_states``, so rviz, Foxglove and
    PlotJuggler read it. Reads ``position``, ``velocity`` and ``effort``; ``~joint_names``
    names them (default joint1, joint2, ...). Needs sensor_msgs (ROS 1 or ROS 2).
    """

    def configure(self) -> None:
        try:
            from sensor_msgs.msg import JointState
        except ImportError:
            raise rtcf.ConfigurationError(
                "JointStateBroadcaster needs sensor_msgs (ROS 2: pip install 'rtcf[ros2]'; "
                "ROS 1: apt install python3-sensor-msgs)"
            ) from None
        self.message = JointState
        self.position = self.add_input("position", np.ndarray)
        self.velocity = self.add_input("velocity", np.ndarray)
        self.effort = self.add_input("effort", np.ndarray)
        self.joint_states = self.add_output("joint_states", JointState)
        self.names = [str(x) for x in self.params.get("~joint_names", [])]
        # the first message made loads its type support (an import, milliseconds):
        # here, not in the loop
        warm = JointState()
        warm.name, warm.position = ["joint"], [0.0]

    def update(self) -> None:
        q = self.position.read()
        if q is None:
            return
        msg = self.message()  # a new one per write (100 Hz): the bridge may still hold the last
        self.stamp_to(msg.header.stamp)
        msg.name = self.names or [f"joint{k + 1}" for k in range(len(q))]
        msg.position = q.tolist()
        for field, port in (("velocity", self.velocity), ("effort", self.effort)):
            value = port.read()
            if value is not None:
                setattr(msg, field, value.tolist())
        self.joint_states.write(msg)


class HoldPosition(rtcf.Component):
    """Holds the arm where it is: ``position_reference`` the position it measured when
    it took over, ``velocity_reference`` zero. A fallback (``fallback:=hold`` on the
    trajectory's launcher): when the trajectory fails, this takes over its topics
    between two iterations, and the controller below holds the arm still against
    gravity, which zero torque would not.
    """

    def configure(self) -> None:
        self.position = self.add_input("position", np.ndarray)
        self.position_reference = self.add_output("position_reference", np.ndarray)
        self.velocity_reference = self.add_output("velocity_reference", np.ndarray)
        self.held: np.ndarray | None = None
        self.still: np.ndarray | None = None  # zero velocity, made once

    def start(self) -> None:
        self.held = None

    def update(self) -> None:
        if self.held is None:
            q = self.position.read()
            if q is None:
                return
            self.held = q.copy()
            self.still = np.zeros_like(self.held)
            self.log.warning("holding the arm at %s", np.round(self.held, 3).tolist())
        self.position_reference.write(self.held)
        self.velocity_reference.write(self.still)
