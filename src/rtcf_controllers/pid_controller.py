"""pid_controller: one PID per degree of freedom, referenced through ``~/reference``.

ros2_controllers' ``pid_controller/PidController`` (Jazzy): ``dof_names``, the state
interfaces it regulates (``reference_and_state_interfaces``: a value, and optionally its
derivative), the command interface it writes (``command_interface``), and control_toolbox's
PID per dof with the gains ``gains.<dof>.*``. Here the interfaces are ports of float64
arrays, one value per dof (docs/controllers.md).
"""

from __future__ import annotations

import math

import numpy as np

import rtcf

from ._layouts import run_from
from ._message_types import message_class
from ._params import ControllerParameters
from ._pid import Gains, Pid, shortest_angular_distance
from ._pid_references import refuse_state, take_measured, take_reference
from ._throttle import Throttled

_isfinite = math.isfinite
_isnan = math.isnan
_NAN = math.nan


class PidController(rtcf.ChainableComponent):
    """Regulates each dof's state (the input named by the first of
    ``reference_and_state_interfaces``, e.g. ``position``; the second, e.g. ``velocity``,
    is its derivative) to the reference and writes ``<command_interface>_command``.

    The reference comes from ``~/reference`` (``control_msgs/MultiDOFCommand``: values
    by ``dof_names`` or, without names, in their order; NaN leaves a dof's reference as
    it is) and stays until the next one; chained, from the reference interfaces
    ``<name>/<dof>/<interface>`` that a preceding controller writes (Jazzy's); with
    ``set_current_state_as_first_setpoint`` each dof starts referenced where it is when
    first measured after the controller starts. A dof is commanded while its reference
    and state are finite; its command is the PID's output plus, with
    ``enable_feedforward``, ``feedforward_gain`` times the reference's derivative (two
    interfaces) or the reference (one).
    ``~/controller_state`` (``control_msgs/MultiDOFStateStamped``) publishes, every
    time it runs, each dof's reference, feedback, error, time step and output.
    With ``use_external_measured_states``, the state comes from ``~/measured_state``
    (``MultiDOFCommand``) instead of the ports.

    Refused (the last good values stay; logged at most once a second per input, and
    counted in ``refused_messages``): a reference with a value or value_dot that is
    infinite (NaN keeps the dof's reference, ros2_controllers' convention), and a state
    (a port's array, or a ``~/measured_state``) with a value that is not finite.
    """

    ros2_control_type = "pid_controller/PidController"

    def configure(self) -> None:
        p = ControllerParameters(self)
        self.dofs = p.names("dof_names", [], non_empty=True)
        n = len(self.dofs)
        state_dofs = p.names("reference_and_state_dof_names", []) or self.dofs
        if len(state_dofs) != n:
            raise p.error("reference_and_state_dof_names", state_dofs,
                          f"{n} names, one per entry of dof_names, or none")
        self.state_dofs = state_dofs
        command_interface = p.text("command_interface", "")
        if not command_interface:
            raise p.error("command_interface", command_interface,
                          "the command interface to write (effort, velocity, ...)")
        interfaces = p.names("reference_and_state_interfaces", [], non_empty=True)
        if len(interfaces) > 2:
            raise p.error("reference_and_state_interfaces", interfaces,
                          "one interface, or two: a value and its derivative")
        self.two = len(interfaces) == 2
        self.first_setpoint = p.flag("set_current_state_as_first_setpoint", True)
        external = p.flag("use_external_measured_states", False)
        self.feedforward = p.flag("enable_feedforward", False)
        self.pids = [Pid(Gains.read(p, dof)) for dof in self.dofs]
        for dof in self.dofs:
            if p.flag(f"gains.{dof}.activate_state_publisher", False):
                self.log.nonrt.warning(
                    "gains.%s.activate_state_publisher: no per-dof pid_state here; "
                    "~/controller_state has every dof", dof)
        command_msg = message_class(self, "control_msgs.msg", "MultiDOFCommand")
        single = message_class(self, "control_msgs.msg", "SingleDOFState")
        self.state_msg = message_class(
            self, "control_msgs.msg", "MultiDOFStateStamped", dof_states=[single()]
        )
        self.reference_port = self.add_input("~/reference", command_msg)
        # Jazzy's reference interfaces: per interface, per dof; the references live there
        self.references = self.add_reference_interfaces(
            [f"{dof}/{name}" for name in interfaces for dof in state_dofs])
        self.reference = self.references[:n]
        self.reference_dot = self.references[n:] if self.two else np.full(n, _NAN)
        self.measured_port = (
            self.add_input("~/measured_state", command_msg) if external else None
        )
        # ros2_control's keys: <reference_and_state_dof>/<interface>, <dof>/<command>
        self.state_ports = [] if external else [
            self.add_state_interfaces(name, [f"{dof}/{name}" for dof in state_dofs])
            for name in interfaces
        ]
        self.command_port = self.add_command_interfaces(
            f"{command_interface}_command", [f"{dof}/{command_interface}" for dof in self.dofs])
        self.controller_state = self.add_output("~/controller_state", self.state_msg)
        self.index = {name: k for k, name in enumerate(state_dofs)}
        self.refused = Throttled(self)  # each kind of problem rate-limited on its own
        self.unknown = Throttled(self)
        self.unnamed = Throttled(self)
        # what was refused, by input (for tests and reports), each said on its own
        inputs = ["~/reference", *(["~/measured_state"] if external else interfaces)]
        self.refused_messages = dict.fromkeys(inputs, 0)
        self.not_finite = {name: Throttled(self) for name in inputs}
        self.output_not_finite = Throttled(self)
        self.refused_samples = 0  # outputs not written: not finite
        self.finite = [np.zeros(n, dtype=bool) for _ in self.state_ports]  # check buffers
        self.command = [_NAN] * n  # what the command interfaces hold (NaN: never written)
        self._lay_out_state(state_dofs)
        self._clear()

    def _lay_out_state(self, dofs: list[str]) -> None:
        """``~/controller_state`` as its bytes (rtcf.Serialized), and a table of its
        numbers, a row per dof (reference, feedback, feedback_dot, error, error_dot,
        time_step, output: the SingleDOFState's, back to back in the bytes)."""
        self.state = rtcf.Serialized(self.state_msg, dof_states=[{"name": d} for d in dofs])
        n = len(dofs)
        self.table = np.zeros((n, 7))
        t = self.table
        self.columns = (t[:, 0], t[:, 1], t[:, 2], t[:, 3], t[:, 4], t[:, 5], t[:, 6])
        self.rows = [(run_from(self.state.view(f"dof_states[{i}].reference"), 7), t[i])
                     for i in range(n)]
        self.wrapped = [i for i, pid in enumerate(self.pids) if pid.gains.angle_wraparound]

    def _clear(self) -> None:
        n = len(self.dofs)
        self.references[:] = _NAN  # (reference and reference_dot are views)
        self.reference_dot[:] = _NAN
        self.measured = [_NAN] * n
        self.measured_dot = [_NAN] * n
        self.seeding = self.first_setpoint

    def start(self) -> None:
        """ros2_controllers' activation: references cleared (and what came while
        inactive dropped), the PIDs reset (``save_i_term`` keeps the integral)."""
        self._clear()
        self.reference_port.read()
        for pid in self.pids:
            pid.reset()

    def update(self) -> None:
        self._measure()
        if not self.in_chained_mode and self.reference_port.has_new_data:
            take_reference(self, self.reference_port.read())
        if self.seeding:
            self._seed()
        self._control(self.period)
        self._publish_state(self.period)

    def _measure(self) -> None:
        port = self.measured_port
        if port is not None:
            if port.has_new_data:
                take_measured(self, port.read())
            return
        n = len(self.dofs)
        for k, port in enumerate(self.state_ports):
            values = port.read()
            if values is None:
                continue
            if len(values) != n:
                self.refused_messages[port.name] += 1
                self.refused.error(
                    "%s has %d values for %d dofs (%s): ignored, the last ones stay",
                    port.topic, len(values), n, ", ".join(self.state_dofs))
                continue
            finite = self.finite[k]
            np.isfinite(values, out=finite)
            if not finite.all():
                refuse_state(self, port.name, port.topic, values, finite)
                continue
            if k:
                self.measured_dot = values.tolist()
            else:
                self.measured = values.tolist()

    def _seed(self) -> None:
        """The first setpoint: each dof's reference where it is, once all are measured."""
        measured, measured_dot = self.measured, self.measured_dot
        if not all(map(_isfinite, measured)):
            return
        for i, value in enumerate(measured):
            if _isnan(self.reference[i]):
                self.reference[i] = value
                if self.two:
                    self.reference_dot[i] = measured_dot[i]
        self.seeding = False

    def _control(self, dt: float) -> None:
        # Python floats (a numpy scalar's overflow warns): the reference interfaces' values
        reference, reference_dot = self.reference.tolist(), self.reference_dot.tolist()
        measured, measured_dot = self.measured, self.measured_dot
        command, two, feedforward = self.command, self.two, self.feedforward
        written = False
        for i, pid in enumerate(self.pids):
            ref, state = reference[i], measured[i]
            if not (_isfinite(ref) and _isfinite(state)):
                continue  # the command interface keeps what it holds
            gains = pid.gains
            out = 0.0
            ref_dot = reference_dot[i]
            if feedforward:
                if not two:
                    out = ref * gains.feedforward_gain
                elif _isfinite(ref_dot):
                    out = ref_dot * gains.feedforward_gain
            if gains.angle_wraparound:
                error = shortest_angular_distance(state, ref)
            else:
                error = ref - state
            if two and _isfinite(ref_dot) and _isfinite(measured_dot[i]):
                out += pid.compute_with_rate(error, ref_dot - measured_dot[i], dt)
            else:
                out += pid.compute(error, dt)
            if not _isfinite(out):  # a finite but huge error overflowed: never written
                self.refused_samples += 1
                pid.reset()  # its integral and last error hold the overflow: start afresh
                self.output_not_finite.error(
                    "%s of %s not written: the output %r is not finite (reference %r, "
                    "state %r); the last command stays, the PID starts afresh",
                    self.command_port.name, self.state_dofs[i], out, ref, state)
                continue
            command[i] = out
            written = True
        if written:  # a new array each time: readers may keep the last one
            self.command_port.write(np.array(command))

    def _publish_state(self, dt: float) -> None:
        reference, feedback, feedback_dot, error, error_dot, time_step, output = self.columns
        reference[:] = self.reference
        feedback[:] = self.measured
        np.subtract(reference, feedback, out=error)
        for i in self.wrapped:
            error[i] = shortest_angular_distance(self.measured[i], float(self.reference[i]))
        if self.two:
            feedback_dot[:] = self.measured_dot
            error_dot[:] = self.reference_dot
            error_dot -= feedback_dot
        time_step[:] = dt
        output[:] = self.command
        for view, row in self.rows:
            view[:] = row
        state = self.state
        state.stamp_ns = self.stamp_ns
        self.controller_state.write(state)
