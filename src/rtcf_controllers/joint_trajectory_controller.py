"""joint_trajectory_controller: follows joint trajectories, from the
``~/follow_joint_trajectory`` action (what MoveIt executes through) or the
``~/joint_trajectory`` topic, as ros2_controllers' JointTrajectoryController does.

Ports are ros2_control's interfaces, one float64 array per interface in the order of
``joints``: ``position`` (and ``velocity``, ``acceleration`` when ``state_interfaces``
lists them) in, ``<interface>_command`` for each of ``command_interfaces`` out.
Behaviour, parameters and defaults are those of ros2_controllers' Jazzy branch
(docs/controllers.md lists them, and what differs).
"""

from __future__ import annotations

from typing import Any

import numpy as np

import rtcf

from . import _jtc_messages as results
from ._jtc_goals import Goals
from ._jtc_messages import Messages
from ._jtc_settings import read_settings
from ._message_types import message_class
from ._throttle import Throttled
from ._tolerances import Checker
from ._trajectory import Trajectory, check, duration_s, from_message, hold


class JointTrajectoryController(rtcf.Component):
    """ros2_controllers' JointTrajectoryController (see the module's docstring)."""

    ros2_control_type = "joint_trajectory_controller/JointTrajectoryController"

    def configure(self) -> None:
        JointTrajectoryControllerState = message_class(
            self, "control_msgs.msg", "JointTrajectoryControllerState")
        from control_msgs.action import FollowJointTrajectory  # control_msgs imports: checked

        for part in (FollowJointTrajectory.Feedback, FollowJointTrajectory.Result):
            part()  # their first message runs their imports: here, not in the loop
        JointTrajectory = message_class(self, "trajectory_msgs.msg", "JointTrajectory")
        self.cfg = cfg = read_settings(self)
        self.joints = joints = cfg.joints
        self.pid = cfg.pid

        # ports: ros2_control's interfaces, and the controller's topics and action
        # ros2_control's <joint>/<interface> keys: the hardware's when the run has some
        self.state_in = {s: self.add_state_interfaces(s, [f"{j}/{s}" for j in joints])
                         for s in self.cfg.state_interfaces}
        self.command_out = {
            c: self.add_command_interfaces(f"{c}_command", [f"{j}/{c}" for j in joints])
            for c in self.cfg.command_interfaces}
        self.trajectory_in = self.add_input("~/joint_trajectory", JointTrajectory)
        self.state_out = self.add_output("~/controller_state", JointTrajectoryControllerState)
        # one goal runs at a time: a newer one preempts it (accept(preempt=...))
        action = self.add_action_server(
            "~/follow_joint_trajectory", FollowJointTrajectory, max_goals=1)
        self.messages = Messages(
            joints, FollowJointTrajectory, JointTrajectoryControllerState,
            has_velocity="velocity" in self.state_in,
            has_acceleration="acceleration" in self.state_in,
            commands=cfg.command_interfaces)
        self.goals = Goals(self, action, self.messages)

        # preallocated: the state, the samples, the error and the commands
        n = len(joints)
        self.actual = np.zeros((3, n))  # rows: position, velocity, acceleration
        self.desired = np.zeros((3, n))
        self.desired_effort = np.zeros(n)
        self.next = np.zeros((3, n))  # the sample one period ahead: the command
        self.next_effort = np.zeros(n)
        self.error = np.zeros((3, n))
        self.pid_command = np.zeros(n)
        self.last_command = np.zeros((3, n))  # for interpolate_from_desired_state
        self.commanded = False  # whether last_command holds a command yet
        self.checker = Checker(n)
        self._position_bounds = cfg.limits.position_bounds(joints)
        self.derivatives = [(row, self.state_in[name]) for row, name in
                            ((1, "velocity"), (2, "acceleration")) if name in self.state_in]
        pid = self.pid is not None
        source = {"position": self.next[0], "acceleration": self.next[2],
                  "velocity": self.pid_command if pid else self.next[1],
                  "effort": self.pid_command if pid else self.desired_effort}
        # (port, what it is written from, a preallocated buffer for the finite check)
        self.sources = [(port, source[name], np.zeros(n, dtype=bool))
                        for name, port in self.command_out.items()]
        self.written: dict[str, np.ndarray] = {}  # port name -> the last command written
        self.trajectory: Trajectory | None = None
        self.holding = True
        # what was refused, by input: read by tests and reports
        self.refused_messages = {"~/joint_trajectory": 0, "~/follow_joint_trajectory": 0}
        self.refused_samples = 0  # samples not written: not finite (defence in depth)
        self.topic_refused = Throttled(self)
        self.sample_refused = Throttled(self)
        self.log.info("joints %s, commands %s, states %s", joints, cfg.command_interfaces,
                      cfg.state_interfaces)

    def start(self) -> None:
        self.trajectory = None  # the first update holds where the joints are
        self.commanded = False
        self.goals.reset()
        if self.pid is not None:
            self.pid.reset()

    def stop(self) -> None:
        self.goals.stop()
        self.trajectory = None

    # -- the loop -------------------------------------------------------------------
    def update(self) -> None:
        position = self.state_in["position"].read()
        if position is None:
            return  # nothing measured yet: command nothing
        actual = self.actual
        actual[0] = position
        for row, port in self.derivatives:
            value = port.read()
            if value is not None:
                actual[row] = value
        t = self.time
        self.goals.poll(t)
        if self.trajectory_in.has_new_data:
            message = self.trajectory_in.read()
            problem = None if message is None else self.follow(message, t)
            if problem is not None:
                self.refused_messages["~/joint_trajectory"] += 1
                self.topic_refused.error(
                    "~/joint_trajectory ignored: %s; the current trajectory goes on", problem)
        if self.trajectory is None:
            self.hold()
        trajectory = self.trajectory
        assert trajectory is not None
        if not trajectory.begun:  # a hold (a new trajectory is begun by follow)
            self._begin(trajectory, t)
        first = not trajectory.sampled
        desired = self.desired
        trajectory.sample(t, desired[0], desired[1], desired[2], self.desired_effort)
        nxt = self.next
        heading = trajectory.sample(t + self.period, nxt[0], nxt[1], nxt[2], self.next_effort,
                                    advance=False)
        before_last = heading < trajectory.n
        since = t - float(trajectory.ends[max(heading - 1, 0)])  # since its segment began

        error = self.error
        np.subtract(desired[0], actual[0], out=error[0])
        if self.cfg.velocity_error:
            np.subtract(desired[1], actual[1], out=error[1])
        if self.cfg.acceleration_error:
            np.subtract(desired[2], actual[2], out=error[2])

        tolerances = self.goals.tolerances
        timed_out = (not before_last and not self.holding and self.cfg.cmd_timeout > 0.0
                     and since > self.cfg.cmd_timeout)
        path_joint = goal_joint = -1
        if (before_last or first) and not self.holding:
            path_joint = self.checker.violation(error, tolerances.path)
        late = False
        if not before_last and not self.holding:
            goal_joint = self.checker.violation(error, tolerances.goal)
            late = goal_joint >= 0 and tolerances.goal_time != 0.0 and since > tolerances.goal_time

        if path_joint < 0 and not late and not self._command(error):
            return  # nothing finite to write: the last command stays
        if self.goals.goal >= 0:
            self.goals.monitor(path_joint, goal_joint, late, timed_out, before_last, since,
                               trajectory)
        elif path_joint >= 0:
            self.log.error("holding position: path tolerance violated (%s)", self.why(
                tolerances.path, path_joint))
            self.hold()
        elif late or timed_out:
            self.log.error("holding position: %s", "goal_time exceeded" if late
                           else f"cmd_timeout {self.cfg.cmd_timeout:g} s")
            self.hold()
        # the rates count this controller's runs (its `rate` may be below the loop's)
        state = self.cfg.state
        if state is not None and state.due(self.iteration // self.every):
            self._publish_state(t - (trajectory.start or 0.0))

    def _command(self, error: np.ndarray) -> bool:
        """Write the commands: the sample one period ahead (through the PID for a
        velocity or effort interface alone). False, and nothing written, if a value
        is not finite."""
        nxt = self.next
        pid = self.pid
        if pid is not None:
            command = self.pid_command
            np.multiply(nxt[1], pid.ff_velocity_scale, out=command)
            if "effort" in self.command_out:
                command += self.next_effort
            pid.compute(error[0], error[1], self.period, command)
        # defence in depth: what follow() accepted samples finite, but a state that
        # is not finite (the hold, the PID) must not reach the hardware either
        for port, source, finite in self.sources:
            np.isfinite(source, out=finite)
            if np.count_nonzero(finite) != finite.size:  # .all() would allocate
                self._not_finite(port.name, source)
                return False
        for port, source, _ in self.sources:
            value = source.copy()  # a port's value must not change once written
            port.write(value)
            self.written[port.name] = value
        self.last_command[:] = nxt
        self.commanded = True
        return True

    def _not_finite(self, port: str, sample: np.ndarray) -> None:
        """A command not finite: not written (the last one stays); a running goal is
        aborted and the joints held where they are, if that is finite."""
        self.refused_samples += 1
        self.sample_refused.error(
            "%s not written: the command %s is not finite; the last command stays, "
            "holding position", port, sample)
        if self.goals.goal >= 0:
            self.goals.end(self.goals.action.abort, results.INVALID_GOAL,
                           "Aborted: the trajectory's command is not finite")
        if not self.holding or np.isfinite(self.actual[0]).all():
            self.hold()  # where the joints are (rare: the allocations are fine)

    # -- trajectories: new ones, holds -------------------------------------------------
    def _begin(self, trajectory: Trajectory, t: float) -> None:
        from_desired = self.cfg.from_desired and self.commanded
        state = self.last_command if from_desired else self.actual
        has_velocity = from_desired or "velocity" in self.state_in
        has_acceleration = from_desired or "acceleration" in self.state_in
        trajectory.begin(t, state[0], state[1] if has_velocity else None,
                         state[2] if has_acceleration else None)

    def hold(self, trajectory: Trajectory | None = None) -> None:
        """Hold where the joints are (zero velocity), or at ``trajectory``'s last point."""
        p, v, a = (self.actual[0].copy(), None, None) if trajectory is None else (
            trajectory.last_point())
        self.trajectory = hold(p, v, a, self.cfg.command_interfaces,
                               interpolate=self.cfg.interpolate)
        self.holding = True

    def follow(self, message: Any, t: float) -> str | None:
        """Follow a trajectory message from now on, or say why not (naming the point,
        the joint and the value)."""
        problem = check(message, self.joints, allow_partial=self.cfg.allow_partial,
                        allow_nonzero_end_velocity=self.cfg.allow_nonzero_end,
                        allow_effort="effort" in self.cfg.command_interfaces,
                        limits=self.cfg.limits)
        if problem is not None:
            return problem
        stamp = message.header.stamp
        stamp_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
        start = None
        if stamp_ns:
            start = t + (stamp_ns - self.stamp_ns) * 1e-9
            end = start + duration_s(message.points[-1].time_from_start)
            if end < t:
                return f"its header stamp {stamp_ns * 1e-9:f} s plus its last point is in the past"
        # joints a partial goal leaves out hold their position command (else the state)
        commanded = self.commanded and "position" in self.command_out
        held = self.last_command[0] if commanded else self.actual[0]
        trajectory = from_message(message, self.joints, lambda j: float(held[j]),
                                  start=start, interpolate=self.cfg.interpolate)
        # begun here, as the update that follows would begin it, so that splines whose
        # coefficients overflow (finite positions too large for their time) are refused
        self._begin(trajectory, t)
        overflow = trajectory.not_finite()
        if overflow is not None:
            k, j, before, span = overflow
            return (f"point {k} position of {self.joints[j]} is "
                    f"{float(trajectory.positions[k, j])!r}: the spline to it from "
                    f"{before!r} in {span:g} s is not finite (too far for its time, or a "
                    "state that is not finite)")
        swing = trajectory.leaves(*self._position_bounds)
        if swing is not None:
            k, j, value = swing
            return (f"its spline to point {k} takes {self.joints[j]} to "
                    f"{self.cfg.limits.outside(self.joints[j], 'position', value)}: too fast "
                    "for the points' spacing")
        self.trajectory = trajectory
        self.holding = False
        return None

    # -- what goes out ------------------------------------------------------------------
    def why(self, tolerance: np.ndarray, joint: int) -> str:
        return Checker.describe(self.error, tolerance, joint, self.joints[joint])

    def _publish_state(self, since: float) -> None:
        self.state_out.write(self.messages.state(
            self, self.desired, self.actual, self.error, self.written, since))
