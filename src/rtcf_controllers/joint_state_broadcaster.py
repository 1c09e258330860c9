"""joint_state_broadcaster: the joints' state interfaces as ``/joint_states``.

What ros2_controllers' ``joint_state_broadcaster/JointStateBroadcaster`` publishes, from
rtcf ports instead of ros2_control's state interfaces: one float64 array per interface,
one value per joint in the order of ``joints`` (docs/controllers.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rtcf

from ._layouts import matrix
from ._message_types import message_class
from ._params import ControllerParameters
from ._throttle import Throttled

FIELDS = ("position", "velocity", "effort")  # JointState's, in its order


class JointStateBroadcaster(rtcf.Component):
    """``sensor_msgs/JointState`` on ``joint_states`` and ``control_msgs/DynamicJointState``
    on ``dynamic_joint_states`` (relative names: ``/joint_states`` in the root namespace;
    ``~/joint_states`` with ``use_local_topics``), stamped with the iteration's time and
    ``frame_id``, every time it runs (its launcher's ``rate``).

    Inputs: one float64 array per state interface, named by it. With both ``joints``
    and ``interfaces`` set, those interfaces; otherwise ``position``, ``velocity`` and
    ``effort`` (or the names ``map_interface_to_joint_state.<field>`` gives them).
    ``joints`` names the arrays' entries; without it the joints are ``joint1``,
    ``joint2``, ... as many as the first array that arrives has. A field whose
    interface has no port, or no value yet, is NaN (as ros2_controllers'). An array of
    the wrong length is logged (rate-limited) and its last good values stay.
    ``extra_joints`` are appended with 0.0 everywhere.
    """

    ros2_control_type = "joint_state_broadcaster/JointStateBroadcaster"

    def configure(self) -> None:
        p = ControllerParameters(self)
        joints = p.names("joints", [])
        interfaces = p.names("interfaces", [])
        self.extra_joints = p.names("extra_joints", [])
        self.frame_id = p.text("frame_id", "base_link")
        local = p.flag("use_local_topics", False)
        dynamic = p.flag("publish_dynamic_joint_states", True)
        p.flag("use_urdf_to_filter", True)  # no URDF in rtcf: `joints` orders them
        mapped = {f: p.text(f"map_interface_to_joint_state.{f}", f) for f in FIELDS}
        if not self.frame_id:
            self.log.nonrt.warning("frame_id is empty: the messages carry none")
        # a field named in `interfaces` is read from that interface itself (ros2's rule)
        source = {f: f if f in interfaces else mapped[f] for f in FIELDS}
        hardware = self.hardware
        present: set[str] | None = None  # (every interface: a joint may lack one)
        if hardware is not None and not (joints and interfaces):
            present = set(hardware.state_keys)
            # every state interface of the hardware, as ros2_controllers' JSB without
            # joints and interfaces: the joints with a JointState field's interface
            joints, names = all_interfaces(hardware.state_keys, set(source.values()))
        elif joints and interfaces:
            names = interfaces
        else:
            names = list(dict.fromkeys(source.values()))
        # what dynamic_joint_states calls each: a mapped interface by its field's name
        shown = {source[f]: f for f in FIELDS}
        self.interfaces = [shown.get(name, name) for name in names]
        if joints:  # ros2_control's <joint>/<interface> keys ("": that joint has none)
            self.ports = [self.add_state_interfaces(
                name, [f"{j}/{name}" if present is None or f"{j}/{name}" in present else ""
                       for j in joints]) for name in names]
        else:  # no joint named: arrays whose length names them
            self.ports = [self.add_input(name, np.ndarray) for name in names]
        # which port's values each JointState field carries (-1: none, NaN)
        self.field_port = [names.index(source[f]) if source[f] in names else -1 for f in FIELDS]
        prefix = "~/" if local else ""
        self.message = message_class(self, "sensor_msgs.msg", "JointState")
        self.joint_states = self.add_output(prefix + "joint_states", self.message)
        self.dynamic_message: Any = None
        if dynamic:
            try:
                interface_value = message_class(self, "control_msgs.msg", "InterfaceValue")
                self.dynamic_message = message_class(
                    self, "control_msgs.msg", "DynamicJointState",
                    interface_values=[interface_value()],
                )
            except rtcf.ConfigurationError as exc:
                if p.has("publish_dynamic_joint_states"):
                    raise
                self.log.nonrt.warning("no dynamic_joint_states: %s", exc)
            else:
                self.interface_value = interface_value
                self.dynamic_joint_states = self.add_output(
                    prefix + "dynamic_joint_states", self.dynamic_message
                )
        self.bad_length = Throttled(self)
        # arrays ignored (the wrong length), by input: for tests and reports
        self.refused_messages = dict.fromkeys((port.name for port in self.ports), 0)
        self.names: list[str] = []
        self.n = 0
        if joints:
            self._name_joints(joints)
        else:  # ros2_control names them from the URDF; here nothing else knows them
            self.log.nonrt.warning(
                "joints not given: the joints are named joint1, joint2, ... as many as the "
                "first array has; give joints (the robot's joint names, in the arrays' order)")

    def _name_joints(self, joints: list[str]) -> None:
        """Everything sized by the joints, made once: the value of each interface per
        joint (the extra joints' zeros at the end), the names, the dynamic layout."""
        n, extra = len(joints), len(self.extra_joints)
        self.n = n
        self.names = [*joints, *self.extra_joints]
        self.values = [np.full(n + extra, math.nan) for _ in self.ports]
        for values in self.values:
            values[n:] = 0.0
        nan = np.full(n + extra, math.nan)
        nan[n:] = 0.0
        fields = [self.values[k] if k >= 0 else nan for k in self.field_port]
        # the messages laid out as their bytes once (rtcf.Serialized): the loop stores
        # the numbers, the stamp, and writes them
        self.js = rtcf.Serialized(self.message, name=self.names,
                                  **dict(zip(FIELDS, fields, strict=True)),
                                  **{"header.frame_id": self.frame_id})
        # (destination view, source values) of each field to copy in the loop
        self.copies = [(self.js.view(f), fields[i]) for i, f in enumerate(FIELDS)
                       if self.field_port[i] >= 0]
        if self.dynamic_message is not None:
            # per joint, its interfaces' values (the extra joints: the fields, zeros)
            names = [self.interfaces] * n + [list(FIELDS)] * extra
            self.dynamic = rtcf.Serialized(
                self.dynamic_message, joint_names=self.names,
                interface_values=[{"interface_names": i, "values": [0.0] * len(i)}
                                  for i in names],
                **{"header.frame_id": self.frame_id})
            # the joints' values as one joints x interfaces view into the bytes (the
            # joints' entries are laid out alike, a fixed stride apart), filled a column
            # per interface in the loop; an extra joint's stay 0
            views = [self.dynamic.view(f"interface_values[{j}].values") for j in range(n)]
            self.copies_dynamic = [] if not n else [
                (column, values[:n])
                for column, values in zip(matrix(views).T, self.values, strict=True)]

    def update(self) -> None:
        for k, port in enumerate(self.ports):
            values = port.read()
            if values is None:
                continue
            if not self.n:
                self._name_joints([f"joint{j + 1}" for j in range(len(values))])
            if len(values) != self.n:
                self.refused_messages[port.name] += 1
                self.bad_length.error(
                    "%s has %d values for %d joints (%s): ignored, the last ones stay",
                    port.topic, len(values), self.n, ", ".join(self.names[: self.n]),
                )
                continue
            self.values[k][: self.n] = values
        if not self.n:
            return  # no joint named, none measured yet: nothing to say
        js = self.js
        js.stamp_ns = self.stamp_ns
        for view, values in self.copies:
            view[:] = values
        self.joint_states.write(js)
        if self.dynamic_message is not None:
            self._write_dynamic()

    def _write_dynamic(self) -> None:
        dynamic = self.dynamic
        dynamic.stamp_ns = self.stamp_ns
        for column, values in self.copies_dynamic:
            column[:] = values
        self.dynamic_joint_states.write(dynamic)


def all_interfaces(keys: tuple[str, ...], fields: set[str]) -> tuple[list[str], list[str]]:
    """(joints, interfaces) of every state interface ``keys``: the prefixes that have one
    of ``fields`` (JointState's position, velocity, effort, as mapped), in the keys'
    order, and every interface name those have."""
    by_joint: dict[str, list[str]] = {}
    for key in keys:
        joint, _, interface = key.rpartition("/")
        by_joint.setdefault(joint, []).append(interface)
    joints = [j for j, names in by_joint.items() if fields.intersection(names)]
    interfaces = list(dict.fromkeys(i for j in joints for i in by_joint[j]))
    return joints, interfaces
