"""The example components."""

from __future__ import annotations

import importlib
import math
import time

import rtcf

_BUILTIN_TYPES: dict[str, type] = {"float": float, "int": int, "bool": bool, "str": str}


def message_class(name: str) -> type:
    """The class of a type name: ``float``, ``pkg/Type`` (ROS 1) or ``pkg/msg/Type`` (ROS 2).

    Both ROS versions generate the Python class ``Type`` in the module ``pkg.msg``.
    """
    if name in _BUILTIN_TYPES:
        return _BUILTIN_TYPES[name]
    parts = name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(parts):
        raise ValueError(
            f"msg_type {name!r} is not float, int, bool, str, pkg/Type (ROS 1) or "
            "pkg/msg/Type (ROS 2)"
        )
    package, type_name = parts
    try:
        cls = getattr(importlib.import_module(f"{package}.msg"), type_name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"msg_type {name!r} cannot be imported: {exc}") from None
    if not isinstance(cls, type):
        raise ValueError(f"msg_type {name!r} is not a class")
    return cls


class BareMinimum(rtcf.Component):
    """Every hook, doing nothing but saying so: a template for your own."""

    def configure(self) -> bool:
        self.log.info("BareMinimum configured")
        return True

    def start(self) -> bool:
        self.log.info("BareMinimum started")
        return True

    def update(self) -> None:
        pass  # put your periodic payload here

    def stop(self) -> None:
        self.log.info("BareMinimum stopping")

    def cleanup(self) -> None:
        self.log.info("BareMinimum cleaning up")


class Identity(rtcf.Component):
    """Copies ``in_port`` to ``out_port`` whenever a new value arrives.

    ``~msg_type`` is the ports' type: ``float`` (the default), ``int``, ``bool``,
    ``str``, or a ROS message type: ``rtcf_example_msgs/Custom`` (ROS 1, the original's
    Identity example, see custom_message/custom_message.launch) or
    ``geometry_msgs/msg/PointStamped`` (ROS 2). A component of your own would just
    import its message class: ``from rtcf_example_msgs.msg import Custom``.
    """

    def configure(self) -> None:
        kind = message_class(str(self.params.get("~msg_type", "float")))
        self.port_in = self.add_input("in_port", kind)
        self.port_out = self.add_output("out_port", kind)

    def update(self) -> None:
        if self.port_in.has_new_data:
            self.port_out.write(self.port_in.read())  # type: ignore[arg-type]


class Mimo(rtcf.Component):
    """Four inputs summed into two outputs (the paper's evaluation payload).

    Inputs that have no value yet count as 0.
    """

    def configure(self) -> None:
        self.in1 = self.add_input("in1", float)
        self.in2 = self.add_input("in2", float)
        self.in3 = self.add_input("in3", float)
        self.in4 = self.add_input("in4", float)
        self.out1 = self.add_output("out1", float)
        self.out2 = self.add_output("out2", float)

    def update(self) -> None:
        total = (
            (self.in1.read() or 0.0)
            + (self.in2.read() or 0.0)
            + (self.in3.read() or 0.0)
            + (self.in4.read() or 0.0)
        )
        self.out1.write(total)
        self.out2.write(total)


class Logging(rtcf.Component):
    """Logs at every level, in configure (non-real-time) and in every update."""

    def configure(self) -> None:
        for level in ("debug", "info", "warning", "error", "fatal"):
            getattr(self.log.nonrt, level)("Test non-RT %s with number %d", level, 12345)

    def update(self) -> None:
        self.log.debug("Test RT debug at iteration %d", self.iteration)
        self.log.info("Test RT info at iteration %d", self.iteration)
        self.log.warning("Test RT warning at iteration %d", self.iteration)
        self.log.error("Test RT error at iteration %d", self.iteration)
        self.log.fatal("Test RT fatal at iteration %d", self.iteration)


class ParameterHandling(rtcf.Component):
    """Reads private (``~``), namespace-relative and absolute parameters at configure time."""

    def configure(self) -> None:
        self.int_param = self.params.get("~int_param", 50)
        self.double_param = self.params.get("~double_param", 0.5)
        self.size = self.params.get("~size", 1)
        self.another_private_param = self.params.get("~another_private_param", 0)
        self.public_param = self.params.get("public_param", 0.0)
        self.log.info(
            "int_param=%s double_param=%s size=%s another_private_param=%s public_param=%s",
            self.int_param,
            self.double_param,
            self.size,
            self.another_private_param,
            self.public_param,
        )

    def update(self) -> None:
        self.log.info("double_param=%s at t=%.3f s", self.double_param, self.time)


class PaperExample(rtcf.Component):
    """Listing 1 of the paper: forwards ``in_port`` to ``out_port``."""

    def configure(self) -> None:
        self.port_in = self.add_input("in_port", float)
        self.port_out = self.add_output("out_port", float)
        self.param = self.params.get("/test_param", 0.0)
        self.log.info("Fetched param with value %s", self.param)

    def update(self) -> None:
        value = self.port_in.read()
        if value is not None:
            self.port_out.write(value)


class Sine(rtcf.Component):
    """A signal source: ``out = offset + amplitude * sin(2 pi frequency_hz t)``."""

    def configure(self) -> None:
        self.out = self.add_output("out", float)
        self.amplitude = float(self.params.get("~amplitude", 1.0))
        self.omega = 2.0 * math.pi * float(self.params.get("~frequency_hz", 1.0))
        self.offset = float(self.params.get("~offset", 0.0))

    def update(self) -> None:
        self.out.write(self.offset + self.amplitude * math.sin(self.omega * self.time))


class Ramp(rtcf.Component):
    """A signal source that grows by ``~step`` (default 1.0) every update, on ``out``."""

    def configure(self) -> None:
        self.out = self.add_output("out", float)
        self.step = float(self.params.get("~step", 1.0))
        self.value = 0.0

    def update(self) -> None:
        self.value += self.step
        self.out.write(self.value)


class Gain(rtcf.Component):
    """``out_port = in_port * ~gain`` (default 1.0001); no value yet counts as 0.

    With Ramp, the trivial chain of ``benchmarks/hot_path.py``: one read, one multiply,
    one write per update.
    """

    def configure(self) -> None:
        self.port_in = self.add_input("in_port", float)
        self.port_out = self.add_output("out_port", float)
        self.gain = float(self.params.get("~gain", 1.0001))

    def update(self) -> None:
        self.port_out.write((self.port_in.read() or 0.0) * self.gain)


class FirstOrderPlant(rtcf.Component):
    """A simulated first-order system ``tau dy/dt = gain u - y`` (explicit Euler).

    Writes ``y`` and ``minus_y`` (for feedback through the summing Mimo).
    """

    def configure(self) -> None:
        self.u = self.add_input("u", float)
        self.y_out = self.add_output("y", float)
        self.minus_y = self.add_output("minus_y", float)
        self.gain = float(self.params.get("~gain", 1.0))
        self.tau = float(self.params.get("~time_constant", 0.05))
        self.y = 0.0

    def start(self) -> None:
        self.alpha = self.period / self.tau

    def update(self) -> None:
        u = self.u.read() or 0.0
        self.y += self.alpha * (self.gain * u - self.y)
        self.y_out.write(self.y)
        self.minus_y.write(-self.y)


class Pid(rtcf.Component):
    """A PID controller: ``command = kp e + ki integral(e) + kd de/dt``.

    ``e = setpoint - measured``.

    It integrates and differentiates over its own period (``self.period``), so the same
    class serves a 2 kHz velocity loop and a 500 Hz position loop: the launcher's
    ``rate`` (or ``every``) is all that differs. The command is clamped to
    ``+-limit``; while it is, the integral stops growing (anti-windup). The gains are
    tunable while it runs. Inputs without a value yet count as 0.
    """

    def configure(self) -> None:
        self.setpoint = self.add_input("setpoint", float)
        self.measured = self.add_input("measured", float)
        self.command = self.add_output("command", float)
        self.kp = self.params.declare("kp", 1.0, description="proportional gain")
        self.ki = self.params.declare("ki", 0.0, description="integral gain [1/s]")
        self.kd = self.params.declare("kd", 0.0, description="derivative gain [s]")
        self.limit = float(self.params.get("~limit", math.inf))
        self.integral = 0.0
        self.previous_error: float | None = None

    def start(self) -> None:
        self.integral = 0.0
        self.previous_error = None

    def update(self) -> None:
        error = (self.setpoint.read() or 0.0) - (self.measured.read() or 0.0)
        dt = self.period
        derivative = 0.0 if self.previous_error is None else (error - self.previous_error) / dt
        self.previous_error = error
        integral = self.integral + error * dt
        u = self.kp.value * error + self.ki.value * integral + self.kd.value * derivative
        if -self.limit <= u <= self.limit:
            self.integral = integral
        else:
            u = math.copysign(self.limit, u)
        self.command.write(u)


class DcMotor(rtcf.Component):
    """A simulated motor with a load: ``J dw/dt = torque - b w``, ``d(angle)/dt = w``.

    Integrated (semi-implicit Euler) over its own period; writes ``position`` [rad]
    and ``velocity`` [rad/s]. It stands where a hardware interface would: first in
    the order (``is_first``), it writes what it measured and reads the command that
    the controllers wrote in the iteration before.
    """

    def configure(self) -> None:
        self.torque = self.add_input("torque", float)
        self.position = self.add_output("position", float)
        self.velocity = self.add_output("velocity", float)
        self.inertia = float(self.params.get("~inertia", 0.01))
        self.damping = float(self.params.get("~damping", 0.05))
        self.w = 0.0
        self.angle = 0.0

    def update(self) -> None:
        dt = self.period
        torque = self.torque.read() or 0.0
        self.w += dt * (torque - self.damping * self.w) / self.inertia
        self.angle += dt * self.w
        self.position.write(self.angle)
        self.velocity.write(self.w)


class StepSupervisor(rtcf.Component):
    """The slow top of a cascade: a position setpoint that steps between ``~low`` and
    ``~high`` every ``~hold_s`` seconds, and the tracking error it watches.

    Writes ``setpoint`` and ``tracking_error`` (setpoint - position, as this
    component saw it); logs a warning when the error stays above ``~max_error`` for
    longer than ``~hold_s`` (a step the loops below did not follow).
    """

    def configure(self) -> None:
        self.position = self.add_input("position", float)
        self.setpoint = self.add_output("setpoint", float)
        self.tracking_error = self.add_output("tracking_error", float)
        self.low = float(self.params.get("~low", 0.0))
        self.high = float(self.params.get("~high", 1.0))
        self.hold_s = float(self.params.get("~hold_s", 0.5))
        self.max_error = float(self.params.get("~max_error", math.inf))
        self.off_since: float | None = None

    def update(self) -> None:
        t = self.time
        target = self.high if int(t / self.hold_s) % 2 == 0 else self.low
        error = target - (self.position.read() or 0.0)
        self.setpoint.write(target)
        self.tracking_error.write(error)
        if abs(error) <= self.max_error:
            self.off_since = None
        elif self.off_since is None:
            self.off_since = t
        elif t - self.off_since > self.hold_s:
            self.log.warning("tracking error %.3f for %.2f s", error, t - self.off_since)
            self.off_since = t


class Busy(rtcf.Component):
    """Stands in for a heavy controller (an MPC, a planner): spins ``~cost_us`` µs of CPU
    per update, then writes ``in_port`` + 1 to ``out_port``.

    The lanes example and ``benchmarks/lanes.py`` put it beside a fast loop, in the
    main lane (it then stalls the loop) or in a lane of its own.
    """

    def configure(self) -> None:
        self.cost_ns = int(float(self.params.get("~cost_us", 100.0)) * 1000)
        self.port_in = self.add_input("in_port", float)
        self.port_out = self.add_output("out_port", float)
        self._clock = time.thread_time_ns  # CPU time: a preemption does not shorten it

    def update(self) -> None:
        end = self._clock() + self.cost_ns
        while self._clock() < end:
            pass
        value = self.port_in.read()
        self.port_out.write((value or 0.0) + 1.0)
