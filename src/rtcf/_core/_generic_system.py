"""``mock_components/GenericSystem``: ros2_control's mock hardware, in Python.

It behaves as ros2_control Jazzy's ``mock_components::GenericSystem``
(``hardware_interface/src/mock_components/generic_system.cpp``) with its parameters
(the ``<hardware>`` tag's ``<param>``\\s):

``calculate_dynamics`` (false)
    Joints follow their command in the mode that the last command mode switch started
    (position by default): a position command gives the position, and velocity and
    acceleration by finite differences; a velocity command gives velocity, position by
    Euler integration and acceleration by difference; an acceleration command gives
    acceleration, then velocity and position by integration. Without it, position
    commands are mirrored to position states and every other joint state to the
    command of the same name.
``position_state_following_offset`` (0.0)
    Added to the position state mirrored from a position command (and to the positions
    at configure); with ``custom_interface_with_following_offset``, the position
    command plus the offset goes to that joint state interface instead.
``custom_interface_with_following_offset`` ("")
    See above; a name no joint has is warned about and ignored.
``mock_sensor_commands`` (false)
    A command interface for every sensor state (same name), mirrored to it.
``mock_gpio_commands`` (false)
    A command interface for every GPIO state that has none, all mirrored to the states.
``disable_commands`` (false)
    Nothing is mirrored: the states keep their values (a driver that lost its hardware).

Always: a NaN command is not mirrored (the state keeps its value: nothing commanded
yet); an infinite command of an interface other than a joint's position is an ERROR of
``read`` (the resource manager then takes the hardware through ``on_error``); joint
states without an ``initial_value`` start at 0.0 at configure (sensor and GPIO states
stay NaN); mimic joints (the URDF's ``<mimic>``) get ``offset + multiplier * position``
of the joint they mimic, and ``multiplier *`` its velocity and acceleration, after the
commands are mirrored. ``bool`` interfaces are copied as they are; the integer and
``float32`` ones are not mirrored (as in Jazzy).

Where rtcf differs: in velocity mode, Jazzy adds the following offset to the position
in every ``read`` while the velocity is not finite (an operator-precedence slip);
rtcf leaves the position as it is. A joint is matched to a mode-switch key by its full
prefix (Jazzy: by substring, so ``joint1`` also matched ``joint10/position``). The
"commands disabled" warning is logged once, not in every ``read``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ._hardware import CallbackReturn, LifecycleState, ReturnType, SystemInterface
from ._hardware_layout import InterfaceDescription
from ._robot_description import HardwareInfo, _as_bool, _as_float

POSITION, VELOCITY, ACCELERATION, EFFORT = "position", "velocity", "acceleration", "effort"
STANDARD_INTERFACES = (POSITION, VELOCITY, ACCELERATION, EFFORT)
_MODES = (POSITION, VELOCITY, ACCELERATION)


class _Mirror:
    """``states[s] = commands[c] + offset`` for index pairs, where the result is finite
    (or always, for bool interfaces), with no allocation: slices when both sides are
    contiguous runs, else gathers and scatters through scratch arrays. ``__call__``
    returns False (and changes nothing) if a command is infinite and ``check_inf``."""

    def __init__(self, states: np.ndarray, commands: np.ndarray, pairs: Sequence[tuple[int, int]],
                 offset: float = 0.0, *, check_inf: bool = True, finite_only: bool = True) -> None:
        self.size = len(pairs)
        s_idx = np.array([s for s, _ in pairs], dtype=np.intp)
        c_idx = np.array([c for _, c in pairs], dtype=np.intp)
        self.states, self.commands = states, commands
        self.offset, self.check_inf, self.finite_only = offset, check_inf, finite_only
        self.s_idx, self.c_idx = s_idx, c_idx
        self.s_view = _run(states, s_idx)
        self.c_view = _run(commands, c_idx)
        self.value = np.empty(self.size)
        self.current = np.empty(self.size)
        self.mask = np.empty(self.size, dtype=bool)

    def __call__(self) -> bool:
        if not self.size:
            return True
        value = self.value
        if self.c_view is not None:
            np.add(self.c_view, self.offset, out=value)
        else:
            np.take(self.commands, self.c_idx, out=value)
            np.add(value, self.offset, out=value)
        if self.check_inf and np.isinf(value, out=self.mask).any():
            return False
        if self.s_view is not None:
            if self.finite_only:
                np.copyto(self.s_view, value, where=np.isfinite(value, out=self.mask))
            else:
                np.copyto(self.s_view, value)
            return True
        if self.finite_only:
            np.take(self.states, self.s_idx, out=self.current)
            np.copyto(self.current, value, where=np.isfinite(value, out=self.mask))
            np.put(self.states, self.s_idx, self.current)
        else:
            np.put(self.states, self.s_idx, value)
        return True


def _run(values: np.ndarray, index: np.ndarray) -> np.ndarray | None:
    """``values[index]`` as a view if ``index`` is a contiguous ascending run."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return values[int(index[0]):int(index[0]) + index.size]
    return None


class GenericSystem(SystemInterface):
    """ros2_control's ``mock_components/GenericSystem`` (see the module's docstring)."""

    def __init__(self) -> None:
        super().__init__()
        self.calculate_dynamics = False
        self.mock_sensor_commands = False
        self.mock_gpio_commands = False
        self.command_propagation_disabled = False
        self.position_state_following_offset = 0.0
        self.custom_interface_with_following_offset = ""
        self.skip_interfaces: tuple[str, ...] = (POSITION,)
        self.joint_control_mode: list[str] = []
        self._warned_disabled = False

    # ------------------------------------------------------------------------ init

    def on_init(self, info: HardwareInfo) -> CallbackReturn:
        params = info.hardware_parameters
        try:
            self.mock_sensor_commands = _as_bool(params.get("mock_sensor_commands", "false"))
            self.mock_gpio_commands = _as_bool(params.get("mock_gpio_commands", "false"))
            self.command_propagation_disabled = _as_bool(params.get("disable_commands", "false"))
            self.calculate_dynamics = _as_bool(params.get("calculate_dynamics", "false"))
            if "position_state_following_offset" in params:
                self.position_state_following_offset = _as_float(
                    params["position_state_following_offset"])
                self.custom_interface_with_following_offset = params.get(
                    "custom_interface_with_following_offset", "").strip()
        except ValueError as exc:
            self.logger.error("hardware '%s': %s", info.name, exc)
            return CallbackReturn.ERROR
        self.skip_interfaces = _MODES if self.calculate_dynamics else (POSITION,)
        custom = self.custom_interface_with_following_offset
        if custom:
            other = {i.name for joint in info.joints
                     for i in (*joint.command_interfaces, *joint.state_interfaces)
                     if i.name not in STANDARD_INTERFACES}
            if custom in other:
                self.logger.info("Custom interface with following offset '%s' found.", custom)
            else:
                self.logger.warning(
                    "Custom interface with following offset '%s' does not exist. Offset will "
                    "not be applied", custom)
        return CallbackReturn.SUCCESS

    def export_unlisted_command_interface_descriptions(self) -> list[InterfaceDescription]:
        found: dict[str, InterfaceDescription] = {}
        groups = []
        if self.mock_sensor_commands:
            groups.append(self.info.sensors)
        if self.mock_gpio_commands:
            groups.append(self.info.gpios)
        for components in groups:
            for component in components:
                commanded = {i.name for i in component.command_interfaces}
                for state in component.state_interfaces:
                    description = InterfaceDescription(component.name, state)
                    if state.name not in commanded:
                        found.setdefault(description.name, description)
        return list(found.values())

    # ------------------------------------------------------------------- configure

    def on_configure(self, previous_state: LifecycleState) -> CallbackReturn:
        offset = self.position_state_following_offset
        for name, description in self.joint_state_interfaces.items():
            if description.data_type != "double":
                continue
            if math.isnan(self.get_state(name)):
                self.set_state(name, 0.0)
            if (description.interface_name == POSITION
                    and not self.custom_interface_with_following_offset):
                self.set_state(name, self.get_state(name) + offset)
        if len(self.joint_control_mode) != len(self.info.joints):
            self.joint_control_mode = [POSITION] * len(self.info.joints)
        self._plan()
        return CallbackReturn.SUCCESS

    def _plan(self) -> None:
        """The index pairs that ``read`` mirrors, fixed once the values are bound."""
        si, ci = self.state_index, self.command_index
        states, commands = self.states, self.commands
        custom = self.custom_interface_with_following_offset
        position_offset = 0.0 if custom else self.position_state_following_offset
        joint_states = self.joint_state_interfaces
        self._position_mirror = _Mirror(states, commands, [
            (si[n], ci[n]) for n, d in self.joint_command_interfaces.items()
            if d.interface_name == POSITION and n in si], position_offset, check_inf=False)
        loop = [d for n, d in joint_states.items()
                if d.interface_name not in self.skip_interfaces and n in ci]
        self._joint_loop = self._mirrors(loop, lambda d: d.data_type)
        self._custom = _Mirror(states, commands, [
            (si[n], ci[f"{d.prefix_name}/{POSITION}"]) for n, d in joint_states.items()
            if custom and d.interface_name == custom and f"{d.prefix_name}/{POSITION}" in ci],
            self.position_state_following_offset, check_inf=False)
        self._dynamics = [
            (j, tuple(si.get(f"{joint.name}/{m}", -1) for m in _MODES),
             tuple(ci.get(f"{joint.name}/{m}", -1) for m in _MODES))
            for j, joint in enumerate(self.info.joints)]
        names = [j.name for j in self.info.joints]
        self._mimic: list[tuple[int, int, float, float]] = []
        for mimic in self.info.mimic_joints:
            mimicking, mimicked = names[mimic.joint_index], names[mimic.mimicked_joint_index]
            for interface, offset in ((POSITION, mimic.offset), (VELOCITY, 0.0),
                                      (ACCELERATION, 0.0)):
                target, source = f"{mimicking}/{interface}", f"{mimicked}/{interface}"
                if target in si and source in si:
                    self._mimic.append((si[target], si[source], mimic.multiplier, offset))
        sensors = ([d for n, d in self.sensor_state_interfaces.items() if n in ci]
                   if self.mock_sensor_commands else [])
        self._sensor_loop = self._mirrors(sensors, lambda d: d.data_type)
        if self.mock_gpio_commands:
            gpios = [d for n, d in self.gpio_state_interfaces.items() if n in ci]
            self._gpio_loop = self._mirrors(gpios, lambda d: d.data_type)
        else:
            gpios = [d for n, d in self.gpio_command_interfaces.items() if n in si]
            self._gpio_loop = self._mirrors(gpios, lambda d: d.data_type)

    def _mirrors(self, descriptions: list[InterfaceDescription],
                 data_type: Callable[[InterfaceDescription], str]) -> tuple[_Mirror, _Mirror]:
        si, ci = self.state_index, self.command_index
        doubles = [(si[d.name], ci[d.name]) for d in descriptions if data_type(d) == "double"]
        bools = [(si[d.name], ci[d.name]) for d in descriptions if data_type(d) == "bool"]
        return (_Mirror(self.states, self.commands, doubles),
                _Mirror(self.states, self.commands, bools, check_inf=False, finite_only=False))

    # ------------------------------------------------------------------ mode switch

    def _joint_of(self, key: str) -> int:
        prefix = key.rpartition("/")[0]
        for j, joint in enumerate(self.info.joints):
            if joint.name == prefix:
                return j
        return -1

    def prepare_command_mode_switch(
        self, start_interfaces: Sequence[str], stop_interfaces: Sequence[str]
    ) -> ReturnType:
        if not self.calculate_dynamics:
            return ReturnType.OK
        joints = self.info.joints
        found = [-1] * len(joints)
        for key in start_interfaces:
            j = self._joint_of(key)
            if j < 0:
                continue
            found[j] = max(found[j], 0)
            if key.rpartition("/")[2] in _MODES:
                found[j] += 1
        result = ReturnType.OK
        for j, count in enumerate(found):
            if count == 0:
                self.logger.error(
                    "Joint '%s' has to have '%s', '%s', or '%s' interface!", joints[j].name,
                    POSITION, VELOCITY, ACCELERATION)
                result = ReturnType.ERROR
            if count > 1:
                self.logger.error(
                    "Got multiple (%d) starting interfaces for joint '%s' - this is not "
                    "supported!", count, joints[j].name)
                result = ReturnType.ERROR
        return result

    def perform_command_mode_switch(
        self, start_interfaces: Sequence[str], stop_interfaces: Sequence[str]
    ) -> ReturnType:
        if not self.calculate_dynamics:
            return ReturnType.OK
        if len(self.joint_control_mode) != len(self.info.joints):
            self.joint_control_mode = [POSITION] * len(self.info.joints)
        for key in start_interfaces:
            j = self._joint_of(key)
            mode = key.rpartition("/")[2]
            if j >= 0 and mode in _MODES:
                self.joint_control_mode[j] = mode
        return ReturnType.OK

    # ------------------------------------------------------------------------ read

    def read(self, time: float, period: float) -> ReturnType:
        if self.command_propagation_disabled:
            if not self._warned_disabled:
                self.logger.warning("Command propagation is disabled - no values will be returned!")
                self._warned_disabled = True
            return ReturnType.OK
        if self.calculate_dynamics:
            offset = (0.0 if self.custom_interface_with_following_offset
                      else self.position_state_following_offset)
            follow_dynamics(self.states, self.commands, self._dynamics, self.joint_control_mode,
                            period, offset)
        else:
            self._position_mirror()
        doubles, bools = self._joint_loop
        if not doubles():
            return ReturnType.ERROR
        bools()
        self._custom()
        states = self.states
        for target, source, multiplier, offset in self._mimic:
            states[target] = offset + multiplier * states[source]
        for doubles, bools in (self._sensor_loop, self._gpio_loop):
            if not doubles():
                return ReturnType.ERROR
            bools()
        return ReturnType.OK


def follow_dynamics(states: np.ndarray, commands: np.ndarray,
                    joints: Sequence[tuple[int, tuple[int, ...], tuple[int, ...]]],
                    modes: Sequence[str], period: float, offset: float) -> None:
    """``calculate_dynamics``: each joint's position, velocity and acceleration states
    (indices, -1 where it has none) from its command in its mode."""
    nan = math.nan
    for j, s_idx, c_idx in joints:
        p, v, a = (float(states[i]) if i >= 0 else nan for i in s_idx)
        cp, cv, ca = (float(commands[i]) if i >= 0 else nan for i in c_idx)
        mode = modes[j]
        if mode == ACCELERATION:
            if math.isnan(v):
                v = 0.0
            if math.isfinite(ca):
                a = ca
            v += 0.0 if math.isnan(a) else a * period
            if math.isfinite(v):
                p += v * period
        elif mode == VELOCITY:
            if math.isfinite(cv):
                old_v = v if math.isfinite(v) else 0.0
                v = cv
                a = (v - old_v) / period
            if math.isfinite(v):
                p += v * period
        elif math.isfinite(cp):
            old_p, old_v = p, (v if math.isfinite(v) else 0.0)
            p = cp + offset
            v = (p - old_p) / period
            a = (v - old_v) / period
        for i, value in zip(s_idx, (p, v, a), strict=True):
            if i >= 0 and math.isfinite(value):
                states[i] = value
