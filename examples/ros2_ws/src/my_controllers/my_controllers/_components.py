"""The components: a PID controller, and a simulated mass to close the loop on."""

from __future__ import annotations

import rtcf


class PidController(rtcf.Component):
    """``command = kp e + ki (integral of e) + kd de/dt`` with ``e = setpoint - measured``.

    The command is clamped to ``[-limit, limit]``; while it is clamped, the integral
    stops growing (anti-windup). Gains and limit are tunable while the loop runs
    (ROS 2 ``set_parameters`` on the component's node). Nothing is written until
    both inputs have a value.
    """

    def configure(self) -> None:
        self.setpoint = self.add_input("setpoint", float)
        self.measured = self.add_input("measured", float)
        self.command = self.add_output("command", float)
        self.kp = self.params.declare("kp", 1.0, min=0.0, description="proportional gain")
        self.ki = self.params.declare("ki", 0.0, min=0.0, description="integral gain")
        self.kd = self.params.declare("kd", 0.0, min=0.0, description="derivative gain")
        self.limit = self.params.declare("limit", 1e6, min=0.0, description="|command| bound")

    def start(self) -> None:
        self.integral = 0.0
        self.last_error: float | None = None

    def update(self) -> None:
        setpoint = self.setpoint.read()
        measured = self.measured.read()
        if setpoint is None or measured is None:
            return
        error = setpoint - measured
        dt = self.period
        derivative = 0.0 if self.last_error is None else (error - self.last_error) / dt
        self.last_error = error
        integral = self.integral + error * dt
        limit = self.limit.value
        command = self.kp.value * error + self.ki.value * integral + self.kd.value * derivative
        if command > limit:
            command = limit
        elif command < -limit:
            command = -limit
        else:
            self.integral = integral  # anti-windup: integrate only while not clamped
        self.command.write(command)


class MassDamper(rtcf.Component):
    """A simulated mass on a viscous damper: ``mass dv/dt = force - damping v``.

    Stands in for a hardware interface: it writes ``position`` and ``velocity`` and
    applies the ``force`` of the iteration before (run it first: ``--is_first``).
    """

    def configure(self) -> None:
        self.force = self.add_input("force", float)
        self.position_out = self.add_output("position", float)
        self.velocity_out = self.add_output("velocity", float)
        self.mass = float(self.params.get("~mass", 1.0))
        self.damping = float(self.params.get("~damping", 0.5))
        self.position = float(self.params.get("~initial_position", 0.0))
        self.velocity = 0.0

    def update(self) -> None:
        force = self.force.read() or 0.0
        dt = self.period
        self.velocity += dt * (force - self.damping * self.velocity) / self.mass
        self.position += dt * self.velocity
        self.position_out.write(self.position)
        self.velocity_out.write(self.velocity)
