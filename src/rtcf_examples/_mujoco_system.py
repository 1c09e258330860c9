"""``rtcf_examples/MujocoSystem``: a MuJoCo model as a ros2_control hardware plugin.

A ``<ros2_control type="system">`` tag whose ``<plugin>`` is ``rtcf_examples/MujocoSystem``
runs its joints in a MuJoCo model, where a robot's drivers would be (docs/hardware.md,
"A hardware plugin in Python: MujocoSystem"). The controllers and their YAML do not know
the difference: a hardware team replaces the plugin with its driver.

``<hardware>`` parameters:

``model`` (required)
    The MJCF file: absolute, or ``<python package>/<path inside it>``
    (``rtcf_examples/models/arm.xml``).
``kp``, ``kd`` (100.0, 10.0)
    The PD that turns a position command into the torque of a joint's motor:
    ``kp (position - q) + kd (velocity - qd)``, with the velocity command where the
    controller claimed one beside the position, else zero.
``kv`` (10.0)
    The gain that turns a velocity command into a motor's torque: ``kv (velocity - qd)``.
``gravity_compensation`` (true)
    In position and velocity modes, a motor also gets the torque that holds the joint
    against gravity (MuJoCo's bias forces), as a driver's own model gives it.

A joint's ``<param>``\\s ``kp``, ``kd`` and ``kv`` override the hardware's for that joint.

Each joint of the description is the model's joint of the same name (a hinge or a slide),
driven by the one actuator that moves it, named anything. What the actuator is decides
what the joint takes: a motor (``<motor>``, torque) takes position (through the PD
above), velocity (through ``kv``) and effort commands; a position servo
(``<position>``) position commands (a velocity command beside them is not used); a
velocity servo (``<velocity>``) velocity commands. Which of a joint's commands drives it
is the last command mode switch's (the interfaces a controller claimed: position,
position and velocity, velocity, or effort); before any, its first command interface.
Until a controller writes (a NaN command) and after it stops, the joint holds its last
target: where it started, for a position.

State interfaces: ``position``, ``velocity``, ``effort`` (the actuators' torque or force
on the joint) and ``acceleration``. Initial positions and velocities are the state
interfaces' ``initial_value``\\s. ``write`` steps the model by its ``period``, in steps of
the model's timestep (a remainder is carried to the next write), the PD computed again
before each step. ``read`` and ``write`` allocate nothing: the views, addresses and
gains are made in ``on_init``, ``on_configure`` and the mode switch (the plan).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

import rtcf

POSITION, VELOCITY, EFFORT, ACCELERATION = "position", "velocity", "effort", "acceleration"
COMMANDS = (POSITION, VELOCITY, EFFORT)
STATES = (POSITION, VELOCITY, EFFORT, ACCELERATION)
MOTOR, POSITION_SERVO, VELOCITY_SERVO = "motor", "position servo", "velocity servo"
# what each kind of actuator takes
TAKES = {MOTOR: COMMANDS, POSITION_SERVO: (POSITION, VELOCITY), VELOCITY_SERVO: (VELOCITY,)}
MODES = ({POSITION}, {POSITION, VELOCITY}, {VELOCITY}, {EFFORT})
DEFAULTS = {"kp": 100.0, "kd": 10.0, "kv": 10.0}


def model_path(text: str, where: str) -> str:
    """The file a ``model`` parameter names: absolute, or ``package/path`` in a Python
    package."""
    text = text.strip()
    example = "rtcf_examples/models/arm.xml"
    if not text:
        raise rtcf.ConfigurationError(
            f"{where}: no <param name=\"model\"> in <hardware>: name the MJCF file, absolute "
            f"or <python package>/<path inside it> ({example})")
    path = Path(text)
    if not path.is_absolute():
        package, _, inside = text.partition("/")
        try:
            path = Path(str(resources.files(package).joinpath(inside)))
        except (ModuleNotFoundError, TypeError, ValueError):
            raise rtcf.ConfigurationError(
                f"{where}: model '{text}': no Python package '{package}'; give an absolute "
                f"path or <python package>/<path inside it> ({example})") from None
    if not path.is_file():
        raise rtcf.ConfigurationError(
            f"{where}: model '{text}': no such file ({path}); give an absolute path or "
            f"<python package>/<path inside it> ({example})")
    return str(path)


def actuator_kind(mujoco: Any, model: Any, a: int) -> str:
    """A motor, a position servo or a velocity servo (or "" for anything else), from
    the actuator's gain and bias as MuJoCo's shortcuts set them."""
    if int(model.actuator_gaintype[a]) != int(mujoco.mjtGain.mjGAIN_FIXED):
        return ""
    bias = int(model.actuator_biastype[a])
    if bias == int(mujoco.mjtBias.mjBIAS_NONE):
        return MOTOR
    if bias == int(mujoco.mjtBias.mjBIAS_AFFINE) and model.actuator_biasprm[a, 0] == 0.0:
        if model.actuator_biasprm[a, 1] != 0.0:
            return POSITION_SERVO
        if model.actuator_biasprm[a, 2] != 0.0:
            return VELOCITY_SERVO
    return ""


class MujocoJoints:
    """A description's joints in a MuJoCo model: the model (``mujoco``, ``model``,
    ``data``, ``path``), and per joint its qpos and dof addresses (``qadr``,
    ``dofadr``), its actuator, the actuator's kind and the scale of its control
    (``ctrl = scale * value``: a motor's 1/(gain gear), a servo's gear), and the gains
    ``kp``, ``kd``, ``kv``. Anything that does not fit is a one-line ConfigurationError
    naming the hardware, the joint and what to do."""

    def __init__(self, info: rtcf.HardwareInfo) -> None:
        where = f"hardware '{info.name}' (<plugin>{info.hardware_plugin_name}</plugin>)"
        self.where = where
        try:
            import mujoco
        except ImportError:
            raise rtcf.ConfigurationError(
                f"{where}: needs the mujoco package: pip install 'rtcf[mujoco]'") from None
        params = info.hardware_parameters
        self.path = model_path(params.get("model", ""), where)
        try:
            model = mujoco.MjModel.from_xml_path(self.path)
        except (ValueError, OSError) as exc:
            raise rtcf.ConfigurationError(f"{where}: model {self.path}: {exc}") from None
        self.mujoco, self.model = mujoco, model
        self.data = mujoco.MjData(model)
        self.gravity_compensation = _flag(params.get("gravity_compensation", "true"),
                                          "gravity_compensation", where)
        gains = {name: _number(params.get(name, str(value)), name, where)
                 for name, value in DEFAULTS.items()}
        joints = info.joints
        n = len(joints)
        self.joint_names = [j.name for j in joints]
        self.qadr = np.zeros(n, dtype=np.intp)
        self.dofadr = np.zeros(n, dtype=np.intp)
        self.actuator = np.zeros(n, dtype=np.intp)
        self.kinds: list[str] = []
        self.scale = np.zeros(n)  # ctrl = scale * value: a motor's 1/(gain gear), a servo's gear
        self.gains = {name: np.zeros(n) for name in DEFAULTS}
        for j, joint in enumerate(joints):
            self.qadr[j], self.dofadr[j], self.actuator[j], kind = self._map(joint, where)
            self.kinds.append(kind)
            a = int(self.actuator[j])
            gear = float(model.actuator_gear[a, 0])
            gain = float(model.actuator_gainprm[a, 0])
            self.scale[j] = 1.0 / (gain * gear) if kind == MOTOR else gear
            for name in DEFAULTS:
                self.gains[name][j] = (_number(joint.parameters[name], name, f"{where} joint "
                                               f"'{joint.name}'")
                                       if name in joint.parameters else gains[name])
            for interface in joint.command_interfaces:
                if interface.name not in TAKES[kind]:
                    raise rtcf.ConfigurationError(
                        f"{where}: joint '{joint.name}' has a {interface.name} command "
                        f"interface, but its actuator '{model.actuator(a).name}' in "
                        f"{self.path} is a {kind}, which takes {' and '.join(TAKES[kind])} "
                        "commands: use a <motor> for any command, or drop the interface")
            for interface in joint.state_interfaces:
                if interface.name not in STATES:
                    raise rtcf.ConfigurationError(
                        f"{where}: joint '{joint.name}' has a state interface "
                        f"'{interface.name}'; MujocoSystem gives {', '.join(STATES)}")
        if info.sensors or info.gpios:
            raise rtcf.ConfigurationError(
                f"{where}: MujocoSystem has joints only; remove the <sensor> and <gpio> tags")

    def _map(self, joint: Any, where: str) -> tuple[int, int, int, str]:
        """The qpos and dof addresses of ``joint`` in the model, its actuator and the
        actuator's kind; a one-line error naming the joint and the model's otherwise."""
        mujoco, model = self.mujoco, self.model
        try:
            jid = int(model.joint(joint.name).id)
        except KeyError:
            names = [model.joint(i).name for i in range(model.njnt)]
            raise rtcf.ConfigurationError(
                f"{where}: joint '{joint.name}' is not in the model {self.path} (its joints: "
                f"{', '.join(n for n in names if n) or 'none'}); name the <joint> as the "
                "model's") from None
        if int(model.jnt_type[jid]) not in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                            int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise rtcf.ConfigurationError(
                f"{where}: joint '{joint.name}' in {self.path} is not a hinge or a slide "
                "joint: MujocoSystem drives joints of one degree of freedom")
        actuators = [a for a in range(model.nu)
                     if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
                     and int(model.actuator_trnid[a, 0]) == jid]
        if len(actuators) != 1:
            raise rtcf.ConfigurationError(
                f"{where}: joint '{joint.name}' has {len(actuators)} actuators in "
                f"{self.path} ({', '.join(model.actuator(a).name for a in actuators) or 'none'})"
                ": MujocoSystem drives a joint through one <motor>, <position> or <velocity>")
        (a,) = actuators
        kind = actuator_kind(mujoco, model, a)
        if not kind:
            raise rtcf.ConfigurationError(
                f"{where}: joint '{joint.name}': its actuator '{model.actuator(a).name}' in "
                f"{self.path} is no <motor>, <position> or <velocity>")
        return int(model.jnt_qposadr[jid]), int(model.jnt_dofadr[jid]), a, kind


class MujocoSystem(rtcf.SystemInterface):
    """ros2_control's hardware interface over a MuJoCo model (see the module's
    docstring)."""

    # ------------------------------------------------------------------------ init

    def on_init(self, info: rtcf.HardwareInfo) -> None:
        joints = MujocoJoints(info)
        self.joints_in_model = joints
        self.where, self.path = joints.where, joints.path
        self.mujoco, self.model, self.data = joints.mujoco, joints.model, joints.data
        self.joint_names, self.kinds = joints.joint_names, joints.kinds
        self.qadr, self.dofadr, self.actuator = joints.qadr, joints.dofadr, joints.actuator
        self.scale = joints.scale
        n = len(self.joint_names)
        self.mode = [_first_mode(joint) for joint in info.joints]
        # each joint's targets, Python floats: per joint, the loop below is faster in
        # floats (from the interpreter's free list, no allocation) than numpy's calls
        self.target = {kind: [0.0] * n for kind in COMMANDS}
        self.plan: tuple[tuple[Any, ...], ...] = ()

    # ------------------------------------------------------------------- configure

    def on_configure(self, previous_state: Any) -> None:
        mujoco, model, data = self.mujoco, self.model, self.data
        mujoco.mj_resetData(model, data)
        for j, joint in enumerate(self.info.joints):
            for interface in joint.state_interfaces:
                if interface.initial_value and interface.name in (POSITION, VELOCITY):
                    value = _number(interface.initial_value, "initial_value",
                                    f"{self.where} joint '{joint.name}'")
                    if interface.name == POSITION:
                        data.qpos[self.qadr[j]] = value
                    else:
                        data.qvel[self.dofadr[j]] = value
        mujoco.mj_forward(model, data)
        self.dt = float(model.opt.timestep)
        # MjData's arrays, once: each attribute access makes a new ndarray (no alloc in write)
        self.qpos, self.qvel, self.bias, self.ctrl = data.qpos, data.qvel, data.qfrc_bias, data.ctrl
        self.pending = 0.0  # the part of a timestep that the last write left over
        # the states, as views of the values, and where each comes from in MjData
        self.reads = []
        for name, source, index in ((POSITION, data.qpos, self.qadr),
                                    (VELOCITY, data.qvel, self.dofadr),
                                    (EFFORT, data.qfrc_actuator, self.dofadr),
                                    (ACCELERATION, data.qacc, self.dofadr)):
            joints = self.joints_with_state(name)
            if joints:
                rows = np.array([self.joint_names.index(j) for j in joints], dtype=np.intp)
                self.reads.append((source, index[rows], self.joint_states(name)))
        # the commands: each interface's view, each value's place in it, and its target
        self.commands_in = tuple(
            (self.joint_commands(name), i, self.target[name], self.joint_names.index(joint))
            for name in COMMANDS for i, joint in enumerate(self.joints_with_command(name)))
        self.hold()
        self._set_gains()
        self.read(0.0, 0.0)
        self.logger.info(
            "%s: %s: %s; %g ms steps", self.info.name, self.path,
            ", ".join(f"{name} ({kind}: {'+'.join(sorted(mode))})" for name, kind, mode
                      in zip(self.joint_names, self.kinds, self.mode, strict=True)),
            self.dt * 1e3)

    def hold(self, rows: Sequence[int] | None = None) -> None:
        """Targets where the joints are, at rest, with no torque of their own."""
        rows = range(len(self.joint_names)) if rows is None else rows
        for j in rows:
            self.target[POSITION][j] = float(self.data.qpos[self.qadr[j]])
            self.target[VELOCITY][j] = 0.0
            self.target[EFFORT][j] = 0.0

    def on_activate(self, previous_state: Any) -> None:
        self.hold()

    # ----------------------------------------------------------------- mode switch

    def _modes_of(self, start: Sequence[str]) -> dict[int, set[str]]:
        found: dict[int, set[str]] = {}
        for key in start:
            joint, _, interface = key.rpartition("/")
            if joint in self.joint_names:
                found.setdefault(self.joint_names.index(joint), set()).add(interface)
        return found

    def prepare_command_mode_switch(self, start_interfaces: Sequence[str],
                                    stop_interfaces: Sequence[str]) -> rtcf.ReturnType:
        for j, mode in self._modes_of(start_interfaces).items():
            kind = self.kinds[j]
            if not _drives(kind, mode):
                self.logger.error(
                    "%s: joint '%s' cannot be commanded by %s (its %s takes: %s)",
                    self.info.name, self.joint_names[j], " and ".join(sorted(mode)), kind,
                    "; ".join(" and ".join(sorted(m)) for m in MODES if _drives(kind, m)))
                return rtcf.ReturnType.ERROR
        return rtcf.ReturnType.OK

    def perform_command_mode_switch(self, start_interfaces: Sequence[str],
                                    stop_interfaces: Sequence[str]) -> rtcf.ReturnType:
        changed = self._modes_of(start_interfaces)
        for j, mode in changed.items():
            self.mode[j] = mode
        self.hold(list(changed))
        self._set_gains()
        return rtcf.ReturnType.OK

    def _set_gains(self) -> None:
        self.plan, self.feedback = plan(self.joints_in_model, self.mode)

    # ----------------------------------------------------------------- read, write

    # No allocation: numpy's ``take`` (positional, mode "clip": the default mode buffers
    # its output) into the state views, and per joint Python floats, which come from the
    # interpreter's free list (numpy's ufuncs cost a microsecond or more a call, and
    # keyword arguments or np.copyto's ``where`` allocate a hundred bytes or more).

    def read(self, time: float, period: float) -> None:
        for source, index, view in self.reads:
            source.take(index, None, view, "clip")

    def write(self, time: float, period: float) -> None:
        for command, i, target, j in self.commands_in:
            value = command.item(i)
            if value == value:  # NaN: no controller wrote it, the last target stays
                target[j] = value
        if not period > 0.0:
            return
        self.pending += period / self.dt
        steps = int(self.pending + 1e-6)
        self.pending -= steps
        mujoco, model, data, ctrl = self.mujoco, self.model, self.data, self.ctrl
        position, velocity, effort = (self.target[POSITION], self.target[VELOCITY],
                                      self.target[EFFORT])
        if not self.feedback:
            for j, _, _, actuator, a, b, c, _, _, _ in self.plan:
                ctrl[actuator] = a * position[j] + b * velocity[j] + c * effort[j]
            if steps:
                mujoco.mj_step(model, data, steps)
            return
        qpos, qvel, bias = self.qpos, self.qvel, self.bias
        for _ in range(steps):
            for j, qadr, dof, actuator, a, b, c, kp, kd, gc in self.plan:
                ctrl[actuator] = (a * position[j] + b * velocity[j] + c * effort[j]
                                  - kp * qpos.item(qadr) - kd * qvel.item(dof)
                                  + gc * bias.item(dof))
            mujoco.mj_step(model, data)


def plan(joints: MujocoJoints, modes: Sequence[set[str]]) -> tuple[tuple[Any, ...], bool]:
    """Per joint, in its mode, the control of its actuator: ``ctrl = a position + b
    velocity + c effort - kp q - kd qd + gc bias`` (the targets, the joint's position,
    velocity and bias force; the actuator's scale folded in), as ``(joint, qpos address,
    dof address, actuator, a, b, c, kp, kd, gc)``; and whether any joint has a part
    that changes with each step (a PD)."""
    rows = []
    gains, gc = joints.gains, 1.0 if joints.gravity_compensation else 0.0
    for j, (kind, mode) in enumerate(zip(joints.kinds, modes, strict=True)):
        kp, kd, kv = gains["kp"][j], gains["kd"][j], gains["kv"][j]
        # a, b, c, kp, kd, gc
        if kind == POSITION_SERVO:
            row = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        elif kind == VELOCITY_SERVO:
            row = (0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
        elif mode == {EFFORT}:
            row = (0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
        elif POSITION in mode:
            row = (kp, kd if VELOCITY in mode else 0.0, 0.0, kp, kd, gc)
        else:
            row = (0.0, kv, 0.0, 0.0, kv, gc)
        scale = float(joints.scale[j])
        rows.append((j, int(joints.qadr[j]), int(joints.dofadr[j]), int(joints.actuator[j]),
                     *(float(x) * scale for x in row)))
    return tuple(rows), any(any(r[7:]) for r in rows)


def _drives(kind: str, mode: set[str]) -> bool:
    """Whether an actuator of ``kind`` can be commanded by the interfaces ``mode``."""
    if kind == POSITION_SERVO:
        return mode in ({POSITION}, {POSITION, VELOCITY})
    if kind == VELOCITY_SERVO:
        return mode == {VELOCITY}
    return mode in MODES


def _first_mode(joint: Any) -> set[str]:
    """A joint's mode before any switch: its first command interface's."""
    for interface in joint.command_interfaces:
        return {interface.name}
    return {POSITION}


def _number(text: str, name: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise rtcf.ConfigurationError(
            f"{where}: <param name=\"{name}\"> is '{text}': give a number")
    return value


def _flag(text: str, name: str, where: str) -> bool:
    lowered = text.strip().lower()
    if lowered not in ("true", "false"):
        raise rtcf.ConfigurationError(
            f"{where}: <param name=\"{name}\"> is '{text}': give true or false")
    return lowered == "true"
