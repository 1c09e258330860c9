"""forward_command_controller and its position/velocity/effort equivalents.

ros2_controllers' ``forward_command_controller/ForwardCommandController`` passes the
values of ``~/commands`` (``std_msgs/Float64MultiArray``) on to one command interface of
each joint; ``position_controllers/JointGroupPositionController`` and its velocity and
effort siblings are the same with ``interface_name`` fixed. Here the command interface
is an output port of float64 arrays, ``<interface_name>_command`` (docs/controllers.md).
"""

from __future__ import annotations

import numpy as np

import rtcf

from ._limits import read_limits
from ._message_types import message_class
from ._params import ControllerParameters
from ._throttle import Throttled


class ForwardCommandController(rtcf.Component):
    """Writes the last accepted ``~/commands`` to ``<interface_name>_command``, one
    value per joint in the order of ``joints``, every time it runs.

    A command of the wrong length (not one value per joint), with a value that is
    not finite, or outside the joint's ``joint_limits.<joint>.*`` for the interface
    (``min_position``/``max_position`` for ``position``, ``max_velocity`` for
    ``velocity``, ``max_effort`` for ``effort``; refused, never clamped) is refused:
    logged naming the joint and the value (rate-limited when it repeats), counted in
    ``refused_messages``, and the last accepted command stays. Nothing is written
    before the first accepted command. Commands that arrive while the controller is
    inactive are dropped when it starts, as ros2_controllers' are at activation.
    """

    ros2_control_type = "forward_command_controller/ForwardCommandController"
    fixed_interface = ""  # the JointGroup*Controller's own interface_name

    def configure(self) -> None:
        p = ControllerParameters(self)
        self.joints = p.names("joints", [], non_empty=True)
        given = p.text("interface_name", "")
        interface = self.fixed_interface or given
        if not interface:
            raise rtcf.ConfigurationError(
                f"component {self.full_name!r}: parameter 'interface_name' is empty; give the "
                "command interface to write (position, velocity, effort, ...)"
            )
        if self.fixed_interface and given and given != self.fixed_interface:
            self.log.nonrt.warning(
                "interface_name %r ignored: %s commands %s", given, type(self).__name__,
                self.fixed_interface,
            )
        self.interface_name = interface
        message = message_class(self, "std_msgs.msg", "Float64MultiArray")
        self.commands = self.add_input("~/commands", message)
        # ros2_control's command interfaces <joint>/<interface_name>: bound to the
        # hardware when the run has some, else the claimed topic <interface>_command
        self.command = self.add_command_interfaces(
            f"{interface}_command", [f"{joint}/{interface}" for joint in self.joints])
        self.value: np.ndarray | None = None
        self.refused = Throttled(self)
        self.refused_messages = {"~/commands": 0}  # what was refused, for tests and reports
        self.limits = read_limits(p, self.joints)
        # the interface's bounds per joint (+-inf: none), compared when a command arrives
        self.low = np.full(len(self.joints), -np.inf)
        self.high = np.full(len(self.joints), np.inf)
        for j, joint in enumerate(self.joints):
            if interface == "position" and joint in self.limits.position:
                self.low[j], self.high[j] = self.limits.position[joint]
            largest = {"velocity": self.limits.velocity,
                       "effort": self.limits.effort}.get(interface, {}).get(joint)
            if largest is not None:
                self.low[j], self.high[j] = -largest, largest

    def start(self) -> None:
        self.commands.read()  # what came while inactive is not applied (ros2's reset)
        self.value = None

    def update(self) -> None:
        if self.commands.has_new_data:
            self._take(self.commands.read())
        value = self.value
        if value is not None:
            self.command.write(value)

    def _take(self, msg: object) -> None:
        data = msg.data  # type: ignore[attr-defined]
        n = len(self.joints)
        if len(data) != n:
            self.refused_messages["~/commands"] += 1
            self.refused.error(
                "%s refused: %d values for %d joints (%s); the last command stays",
                self.commands.topic, len(data), n, ", ".join(self.joints),
            )
            return
        value = np.array(data, dtype=float)  # a new array per command: readers may keep it
        # where a value is not finite, or outside its joint's limits
        bad = ~(np.isfinite(value) & (value >= self.low) & (value <= self.high))
        if bad.any():
            j = int(bad.argmax())
            x = float(value[j])
            why = (f"{x!r} (not finite)" if not np.isfinite(x) else
                   self.limits.outside(self.joints[j], self.interface_name, x))
            self.refused_messages["~/commands"] += 1
            self.refused.warning("%s refused: %s of %s is %s; the last command stays",
                                 self.commands.topic, self.interface_name, self.joints[j], why)
            return
        self.value = value


class JointGroupPositionController(ForwardCommandController):
    """``position_controllers/JointGroupPositionController``: ``~/commands`` to
    ``position_command``."""

    ros2_control_type = "position_controllers/JointGroupPositionController"
    fixed_interface = "position"


class JointGroupVelocityController(ForwardCommandController):
    """``velocity_controllers/JointGroupVelocityController``: ``~/commands`` to
    ``velocity_command``."""

    ros2_control_type = "velocity_controllers/JointGroupVelocityController"
    fixed_interface = "velocity"


class JointGroupEffortController(ForwardCommandController):
    """``effort_controllers/JointGroupEffortController``: ``~/commands`` to
    ``effort_command``; zero effort on every joint when it stops (as ros2_controllers'
    does at deactivation), so that no torque stays applied."""

    ros2_control_type = "effort_controllers/JointGroupEffortController"
    fixed_interface = "effort"

    def stop(self) -> None:
        self.command.write(np.zeros(len(self.joints)))
