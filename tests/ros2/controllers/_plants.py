"""Hardware for the controllers' tests: joints that go where they are told, wheels that
turn as fast as they are told, and a mass pushed by an effort. Each writes ros2_control's
state interfaces as float64 arrays, one value per joint, and runs first (``is_first``),
as a driver does."""

from __future__ import annotations

import numpy as np

import rtcf


class PositionJoints(rtcf.Component):
    """Joints that reach ``position_command`` in one period: ``position`` is the last
    command (``~initial_positions`` before one), ``velocity`` how far that moved them
    in the period, ``effort`` ``~effort`` (constant)."""

    def configure(self) -> None:
        self.q = np.array(self.params.get("~initial_positions", [0.0, 0.0, 0.0]), dtype=float)
        self.held = float(self.params.get("~effort", 0.0))
        self.position_command = self.add_input("position_command", np.ndarray)
        self.position = self.add_output("position", np.ndarray)
        self.velocity = self.add_output("velocity", np.ndarray)
        self.effort = self.add_output("effort", np.ndarray)

    def update(self) -> None:
        command = self.position_command.read()
        q = self.q if command is None else command
        self.velocity.write((q - self.q) / self.period)
        self.q = q
        self.position.write(q)
        self.effort.write(np.full(len(q), self.held))


class Mass(rtcf.Component):
    """Point masses of ``~mass`` kg on a line, ``effort_command`` the force on each
    (none yet: 0), integrated by semi-implicit Euler once per period."""

    command_name, default_joints = "effort_command", 1

    def configure(self) -> None:
        n = int(self.params.get("~joints", self.default_joints))
        self.mass = float(self.params.get("~mass", 1.0))
        self.x = np.zeros(n)
        self.v = np.zeros(n)
        self.command = self.add_input(self.command_name, np.ndarray)
        self.position = self.add_output("position", np.ndarray)
        self.velocity = self.add_output("velocity", np.ndarray)

    def update(self) -> None:
        force = self.command.read()
        if force is not None:
            self.v = self.v + force / self.mass * self.period
            self.x = self.x + self.v * self.period
        self.position.write(self.x)
        self.velocity.write(self.v)


class VelocityJoints(Mass):
    """``~joints`` joints (2: a base's wheels) that turn at ``velocity_command`` at once
    (none yet: 0): ``position`` integrates it once per period, ``velocity`` is it."""

    command_name, default_joints = "velocity_command", 2

    def update(self) -> None:
        command = self.command.read()
        if command is not None:
            self.v = command
        self.x = self.x + self.v * self.period
        self.position.write(self.x)
        self.velocity.write(self.v)


class SaysWhen(rtcf.Component):
    """Logs the iteration each ``start`` and ``stop`` runs in: a switch seen from outside."""

    def start(self) -> bool:
        self.log.nonrt.info("start at iteration %d", self.iteration)
        return True

    def stop(self) -> None:
        self.log.nonrt.info("stop at iteration %d", self.iteration)


class RefusesRestart(SaysWhen):
    """Starts once; each later ``start`` fails (returns False): a controller whose
    activation a switch cannot make, for the switch's rollback."""

    def configure(self) -> None:
        self.starts = 0

    def start(self) -> bool:
        self.starts += 1
        return super().start() and self.starts == 1
