"""The resource manager: every hardware of a robot description, their values, their claims.

ros2_control's ``ResourceManager`` without middleware: built from
:func:`._robot_description.parse`'s :class:`HardwareInfo`\\s, it loads each hardware by
its ``<plugin>`` (:mod:`._hardware_plugins`), runs ``on_init``, and from then on:

* holds every hardware's values in **one buffer per direction**: :attr:`states` and
  :attr:`commands` (float64), each hardware's arrays being slices of them
  (:meth:`HardwareComponentInterface.bind_values`); ``state_indices(keys)`` and
  ``command_indices(keys)`` give controllers index arrays into them, to gather
  (``np.take(rm.states, idx, out=buf)``) and scatter (``np.put(rm.commands, idx,
  values)``) with no allocation;
* drives each hardware's lifecycle with ros2_control's rules
  (:meth:`set_hardware_component_state`, :meth:`set_initial_states` for the controller
  manager's ``hardware_components_initial_state``); a configured (inactive or active)
  hardware's interfaces are *available*, an unconfigured or finalized one's are not;
* runs the loop's two calls: :meth:`read_all` (every inactive and active hardware,
  each at its ``rw_rate``) and :meth:`write_all` (every active one). A hardware whose
  ``read`` or ``write`` returns ERROR (or raises) goes through ``on_error`` and its
  interfaces become unavailable; so does every hardware of its ``<group>``; a
  ``write`` that returns DEACTIVATE deactivates it (from ``read``, DEACTIVATE counts as
  ERROR, as in Jazzy). The names of the failed ones are in the returned status, for the
  controller manager to deactivate the controllers that use them
  (:meth:`InterfaceClaims.controllers_using`);
* claims command interfaces per ``joint/interface`` key for controllers
  (:class:`._interface_claims.InterfaceClaims`, :attr:`claims`), chainable controllers'
  reference interfaces among them (:attr:`references`);
* answers ``list_hardware_components`` and ``list_hardware_interfaces`` with the
  fields of controller_manager_msgs.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from ._controller_references import ControllerReferences
from ._errors import ConfigurationError
from ._hardware import HardwareComponentInterface, LifecycleState, ReturnType
from ._hardware_component import HardwareComponent
from ._hardware_layout import Layout
from ._hardware_plugins import load_hardware_class
from ._interface_claims import InterfaceClaims
from ._lifecycle import ACTIVE, FINALIZED, INACTIVE, STATE_LABELS, UNCONFIGURED, UNKNOWN
from ._robot_description import HardwareInfo, parse

_OK, _ERROR, _DEACTIVATE = ReturnType.OK, ReturnType.ERROR, ReturnType.DEACTIVATE
_TYPE_ORDER = {"actuator": 0, "sensor": 1, "system": 2}  # Jazzy's order of read and write
_LABELS = {label: state for state, label in STATE_LABELS.items() if state <= FINALIZED}


@dataclass(frozen=True)
class HardwareInterfaceState:
    """controller_manager_msgs/HardwareInterface."""

    name: str
    data_type: str
    is_available: bool
    is_claimed: bool


@dataclass(frozen=True)
class HardwareComponentState:
    """controller_manager_msgs/HardwareComponentState."""

    name: str
    type: str
    is_async: bool
    rw_rate: int
    plugin_name: str
    state: LifecycleState
    command_interfaces: tuple[HardwareInterfaceState, ...]
    state_interfaces: tuple[HardwareInterfaceState, ...]


class SetStateResult(NamedTuple):
    """controller_manager_msgs/SetHardwareComponentState's response."""

    ok: bool
    state: LifecycleState


@dataclass
class ReadWriteStatus:
    """What :meth:`ResourceManager.read_all` and ``write_all`` return (one object per
    direction, reused: copy ``failed_hardware_names`` to keep it)."""

    result: ReturnType = ReturnType.OK
    failed_hardware_names: list[str] = field(default_factory=list)


class ResourceManager:
    """Every hardware of a robot description (see the module's docstring).

    ``update_rate`` is the loop's rate (the controller manager's ``update_rate``): a
    hardware's ``rw_rate`` of 0 or above it becomes it. Hardware starts unconfigured,
    as ros2_control's resource manager leaves it; :meth:`set_initial_states` then does
    what the controller manager does at start (by default: every hardware active).
    """

    def __init__(
        self,
        infos: Sequence[HardwareInfo],
        update_rate: int = 100,
        *,
        allow_controller_activation_with_inactive_hardware: bool = False,
        load: Callable[[HardwareInfo], type[HardwareComponentInterface]] = load_hardware_class,
        logger: Any = None,
    ) -> None:
        if update_rate <= 0:
            raise ConfigurationError(f"update_rate must be positive, got {update_rate}")
        self.update_rate = update_rate
        self.logger = logger if logger is not None else logging.getLogger(
            "rtcf.resource_manager")
        self.components: dict[str, HardwareComponent] = {}
        for info in infos:
            if info.name in self.components:
                raise ConfigurationError(
                    f"Hardware name {info.name} is duplicated. Please provide a unique 'name' "
                    "in the URDF.")
            self.components[info.name] = self._load(info, load)
        self._layouts = {name: c.impl.export_interfaces() for name, c in self.components.items()}
        self._validate(infos)
        self.states, self.state_keys, self._state_owner = self._buffer(0)
        self.commands, self.command_keys, self._command_owner = self._buffer(1)
        self.state_index = {key: i for i, key in enumerate(self.state_keys)}
        self.command_index = {key: i for i, key in enumerate(self.command_keys)}
        s = c = 0
        for name, component in self.components.items():
            n_states, n_commands = (len(lay) for lay in self._layouts[name])
            component.impl.bind_values(self.states[s:s + n_states],
                                       self.commands[c:c + n_commands])
            s, c = s + n_states, c + n_commands
        self._data_types = {
            key: dt for lay, _ in self._layouts.values()
            for key, dt in zip(lay.names, lay.data_types, strict=True)}
        self._command_data_types = {
            key: dt for _, lay in self._layouts.values()
            for key, dt in zip(lay.names, lay.data_types, strict=True)}
        self.available_states: set[str] = set()
        self.available_commands: set[str] = set()
        self._group_state = {c.group: _OK for c in self.components.values() if c.group}
        ordered = sorted(self.components.values(), key=lambda c: _TYPE_ORDER[c.info.type])
        self._readers = tuple(ordered)
        self._writers = tuple(c for c in ordered if not c.is_sensor)
        self.read_status = ReadWriteStatus()
        self.write_status = ReadWriteStatus()
        # chainable controllers' reference interfaces: command keys of controllers
        self.references = ControllerReferences()
        self.claims = InterfaceClaims(
            self, allow_controller_activation_with_inactive_hardware, self.logger)

    @classmethod
    def from_urdf(cls, urdf_text: str, update_rate: int = 100, *,
                  source: str = "robot_description", **options: Any) -> ResourceManager:
        """A resource manager for every ``<ros2_control>`` tag of a URDF."""
        return cls(parse(urdf_text, source), update_rate, **options)

    # --------------------------------------------------------------------- loading

    def _load(self, info: HardwareInfo,
              load: Callable[[HardwareInfo], type[HardwareComponentInterface]]
              ) -> HardwareComponent:
        cls = load(info)
        try:
            impl = cls()
        except Exception as exc:
            raise ConfigurationError(
                f"Exception of type : {type(exc).__name__} occurred while loading hardware "
                f"'{info.name}': {exc}") from None
        rw_rate = info.rw_rate
        if rw_rate == 0 or rw_rate > self.update_rate:
            rw_rate = self.update_rate
            # as ros2_control's resource manager: the plugin's on_init sees the rate it
            # is read and written at (a bus plans its load from it at configure)
            info = replace(info, rw_rate=rw_rate)
        child = getattr(self.logger, "getChild", None)  # a worker's: its log ring
        logger = child(info.name) if child is not None else logging.getLogger(
            f"{getattr(self.logger, 'name', 'rtcf')}.{info.name}")
        component = HardwareComponent(impl, info, rw_rate, logger)
        if component.initialize() != UNCONFIGURED:
            why = component.last_failure  # what on_init raised, if it did
            raise ConfigurationError(
                f"{info.type.capitalize()} hardware component '{info.name}' from plugin "
                f"'{info.hardware_plugin_name}' failed to initialize." + (f" {why}" if why
                                                                          else ""))
        return component

    def _validate(self, infos: Sequence[HardwareInfo]) -> None:
        """Every interface of the description exported, no key exported twice."""
        owners: list[dict[str, str]] = [{}, {}]
        for name, layouts in self._layouts.items():
            for direction, lay in enumerate(layouts):
                for key in lay.names:
                    if key in owners[direction]:
                        kind = ("State", "Command")[direction]
                        raise ConfigurationError(
                            f"hardware '{name}': ResourceStorage: Tried to insert {kind}Interface "
                            f"with already existing key. Insert[{key}] (hardware "
                            f"'{owners[direction][key]}' exports it too)")
                    owners[direction][key] = name
        missing: list[list[str]] = [[], []]
        for info in infos:
            expected = [
                [f"{c.name}/{i.name}" for c in (*info.joints, *info.sensors, *info.gpios)
                 for i in c.state_interfaces],
                [f"{c.name}/{i.name}" for c in (*info.joints, *info.gpios)
                 for i in c.command_interfaces],
            ]
            for direction in (0, 1):
                missing[direction] += [k for k in expected[direction]
                                       if k not in owners[direction]]
        if missing[0] or missing[1]:
            raise ConfigurationError(
                "Discrepancy between robot description file (urdf) and actually exported HW "
                "interfaces. Details: Wrong state or command interface configuration. missing "
                f"state interfaces: {' '.join(missing[0]) or '-'}; missing command interfaces: "
                f"{' '.join(missing[1]) or '-'}")

    def _buffer(self, direction: int) -> tuple[np.ndarray, tuple[str, ...], dict[str, str]]:
        keys: list[str] = []
        owner: dict[str, str] = {}
        for name, layouts in self._layouts.items():
            lay: Layout = layouts[direction]
            keys.extend(lay.names)
            owner.update(dict.fromkeys(lay.names, name))
        return np.full(len(keys), np.nan), tuple(keys), owner

    # ------------------------------------------------------------------ the loop's

    def read_all(self, time: float, period: float) -> ReadWriteStatus:
        """Every inactive and active hardware's ``read`` (ros2_control's order:
        actuators, sensors, systems), each at its ``rw_rate``."""
        status = self.read_status
        status.result = _OK
        failed = status.failed_hardware_names
        failed.clear()
        rate = self.update_rate
        groups = self._group_state
        for component in self._readers:
            if component.rw_rate == rate:
                result = component.read(time, period)
            else:
                due = component.due(time, component.last_read_time, rate)
                result = component.read(time, due) if due == due else _OK
            if component.group:
                if result is not _OK:
                    groups[component.group] = result
                result = groups[component.group]
            if result is not _OK:
                if result is _DEACTIVATE:
                    self.logger.warning(
                        "DEACTIVATE returned from read cycle is treated the same as ERROR.")
                component.error()
                status.result = _ERROR
                failed.append(component.name)
                self._make_unavailable(component.name)
        return status

    def write_all(self, time: float, period: float) -> ReadWriteStatus:
        """Every active hardware's ``write`` (actuators, then systems)."""
        status = self.write_status
        status.result = _OK
        failed = status.failed_hardware_names
        failed.clear()
        rate = self.update_rate
        groups = self._group_state
        for component in self._writers:
            if component.rw_rate == rate:
                result = component.write(time, period)
            else:
                due = component.due(time, component.last_write_time, rate)
                result = component.write(time, due) if due == due else _OK
            if component.group:
                if result is not _OK:
                    groups[component.group] = result
                result = groups[component.group]
            if result is _ERROR:
                component.error()
                status.result = _ERROR
                failed.append(component.name)
                self._make_unavailable(component.name)
            elif result is _DEACTIVATE:
                self._set_state(component, INACTIVE)
                status.result = _DEACTIVATE
                failed.append(component.name)
        return status

    # ------------------------------------------------------------------- lifecycle

    def set_initial_states(
        self, unconfigured: Iterable[str] = (), inactive: Iterable[str] = (), *,
        shutdown_on_initial_state_failure: bool = True,
    ) -> None:
        """The controller manager's ``hardware_components_initial_state``: the hardware
        named in ``unconfigured`` stays so, that in ``inactive`` is configured, every
        other one is activated (a ``<group>``'s all configured, then all activated,
        rolled back to inactive if one fails to activate). A failure raises a
        ConfigurationError if ``shutdown_on_initial_state_failure`` (Jazzy's default),
        else it is logged."""
        remaining = dict(self.components)

        def set_to(name: str, target: int) -> bool:
            if self.set_hardware_component_state(name, target).ok:
                return True
            message = (f"Failed to set the initial state of the component : {name} to "
                       f"{STATE_LABELS[target]}")
            if shutdown_on_initial_state_failure:
                raise ConfigurationError(message)
            self.logger.error("%s", message)
            return False

        for names, target in ((unconfigured, UNCONFIGURED), (inactive, INACTIVE)):
            for name in names:
                if not name:
                    continue
                if name not in self.components:
                    self.logger.warning(
                        "Hardware component '%s' is unknown, therefore not set in '%s' state.",
                        name, STATE_LABELS[target])
                    continue
                set_to(name, target)
                remaining.pop(name, None)
        groups: dict[str, list[str]] = {}
        for name, component in remaining.items():
            if component.group:
                groups.setdefault(component.group, []).append(name)
        for members in groups.values():
            if not all(set_to(name, INACTIVE) for name in members):
                continue
            activated: list[str] = []
            for name in members:
                if not set_to(name, ACTIVE):
                    for done in activated:
                        self.set_hardware_component_state(done, INACTIVE)
                    break
                activated.append(name)
        for name, component in remaining.items():
            if not component.group:
                set_to(name, ACTIVE)

    def set_hardware_component_state(
        self, name: str, target: int | str | LifecycleState
    ) -> SetStateResult:
        """Take hardware ``name`` to ``target`` (a lifecycle_msgs/State id, a label, or a
        LifecycleState; id 0 with a label means the label), through the states between,
        as ros2_control does: ``ok`` if it got there, and the state it is in."""
        component = self.components.get(name)
        if component is None:
            self.logger.error("hardware component with name '%s' does not exist", name)
            return SetStateResult(False, LifecycleState(UNKNOWN, ""))
        if isinstance(target, LifecycleState):
            target = target.id if target.id else target.label
        if isinstance(target, str):
            target = _LABELS.get(target, -1)
        ok = self._set_state(component, target)
        return SetStateResult(ok, LifecycleState.of(component.state))

    def shutdown_components(self) -> bool:
        """Every hardware to finalized; True if all got there."""
        return all([self._set_state(c, FINALIZED) for c in self.components.values()])

    def _set_state(self, component: HardwareComponent, target: int) -> bool:
        """ros2_control's ``ResourceStorage::set_component_state``."""
        current = component.state
        if current == FINALIZED and target != FINALIZED:
            self.logger.warning(
                "hardware '%s' is in finalized state and can be only destroyed.", component.name)
            return False
        if target == UNCONFIGURED:
            if current == ACTIVE:
                return self._step(component, "deactivate") and self._step(component, "cleanup")
            return current == UNCONFIGURED or self._step(component, "cleanup")
        if target == INACTIVE:
            if current == UNCONFIGURED:
                return self._step(component, "configure")
            return current == INACTIVE or self._step(component, "deactivate")
        if target == ACTIVE:
            if current == UNCONFIGURED:
                return self._step(component, "configure") and self._step(component, "activate")
            return current == ACTIVE or self._step(component, "activate")
        if target == FINALIZED:
            if current == ACTIVE:
                return self._step(component, "deactivate") and self._step(component, "shutdown")
            return current == FINALIZED or self._step(component, "shutdown")
        return False

    _GOALS = {"configure": INACTIVE, "cleanup": UNCONFIGURED, "activate": ACTIVE,
              "deactivate": INACTIVE, "shutdown": FINALIZED}

    def _step(self, component: HardwareComponent, transition: str) -> bool:
        self.logger.info("'%s' hardware '%s' ", transition, component.name)
        reached = getattr(component, transition)() == self._GOALS[transition]
        if reached:
            self.logger.info("Successful '%s' of hardware '%s'", transition, component.name)
        else:
            self.logger.error("Failed to '%s' hardware '%s'", transition, component.name)
        if transition == "configure" and reached:
            states, commands = self._layouts[component.name]
            self.available_states.update(states.names)
            self.available_commands.update(commands.names)
        if transition in ("cleanup", "shutdown") and reached:
            self._make_unavailable(component.name)
        if component.group and (transition in ("configure", "cleanup")
                                or (transition == "shutdown" and reached)):
            self._group_state[component.group] = _OK
        return reached

    def _make_unavailable(self, name: str) -> None:
        states, commands = self._layouts[name]
        self.available_states.difference_update(states.names)
        self.available_commands.difference_update(commands.names)

    # -------------------------------------------------------------- what it exports

    def command_owners(self) -> Iterator[tuple[HardwareComponent, Mapping[str, int]]]:
        """Each hardware that is written (actuators, then systems) and its command
        interfaces' indices by key (the claims' mode switches ask them)."""
        for component in self._writers:
            yield component, self._layouts[component.name][1].index

    def hardware_of(self, key: str) -> str:
        """The hardware that exports command or state interface ``key`` ("" if none)."""
        return self._command_owner.get(key) or self._state_owner.get(key, "")

    def state_interface_exists(self, key: str) -> bool:
        return key in self.state_index

    def command_interface_exists(self, key: str) -> bool:
        """A hardware's command interface, or a controller's reference interface."""
        return key in self.command_index or key in self.references

    def state_interface_is_available(self, key: str) -> bool:
        return key in self.available_states

    def command_interface_is_available(self, key: str) -> bool:
        return key in self.available_commands or self.references.is_available(key)

    def state_indices(self, keys: Iterable[str]) -> np.ndarray:
        """Positions of state interfaces ``keys`` in :attr:`states` (an intp array)."""
        return self._indices(keys, self.state_index, "State")

    def command_indices(self, keys: Iterable[str]) -> np.ndarray:
        """Positions of command interfaces ``keys`` in :attr:`commands` (an intp array)."""
        return self._indices(keys, self.command_index, "Command")

    def _indices(self, keys: Iterable[str], index: Mapping[str, int], kind: str) -> np.ndarray:
        found = []
        for key in keys:
            if key not in index:
                raise ConfigurationError(f"{kind} interface with key '{key}' does not exist")
            found.append(index[key])
        return np.array(found, dtype=np.intp)

    def list_hardware_components(self) -> list[HardwareComponentState]:
        """controller_manager's ``~/list_hardware_components``, in the description's order."""
        answer = []
        for name, component in self.components.items():
            states, commands = self._layouts[name]
            info = component.info
            answer.append(HardwareComponentState(
                name=name, type=info.type, is_async=info.is_async, rw_rate=component.rw_rate,
                plugin_name=info.hardware_plugin_name,
                state=LifecycleState.of(component.state),
                command_interfaces=tuple(self._command_state(k) for k in commands.names),
                state_interfaces=tuple(self._state_state(k) for k in states.names)))
        return answer

    def list_hardware_interfaces(
        self,
    ) -> tuple[list[HardwareInterfaceState], list[HardwareInterfaceState]]:
        """controller_manager's ``~/list_hardware_interfaces``: the state and the command
        interfaces, each sorted by name."""
        return ([self._state_state(k) for k in sorted(self.state_keys)],
                [self._command_state(k) for k in sorted(self.command_keys)])

    def _state_state(self, key: str) -> HardwareInterfaceState:
        return HardwareInterfaceState(key, self._data_types[key], key in self.available_states,
                                      False)

    def _command_state(self, key: str) -> HardwareInterfaceState:
        return HardwareInterfaceState(
            key, self._command_data_types[key], key in self.available_commands,
            self.claims.is_claimed(key))
