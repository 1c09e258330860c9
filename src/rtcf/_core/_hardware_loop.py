"""The hardware in the loop: a robot description's resource manager, run by the schedule.

A runner whose settings carry a robot description (``robot_description`` or
``robot_description_file``) builds a :class:`ResourceManager` when it is built (in a
worker: the loop's own process), with every ``<ros2_control>`` hardware loaded,
initialised and taken to its initial state (``hardware_components_initial_state``, as
ros2_control's controller manager reads it). Its schedule then runs ros2_control's order
in every iteration (rtcf._core._schedule):

1. one **read** step: ``read_all(time, period)`` on the loop's time;
2. the components in their data-flow order; each port that is a set of hardware
   interfaces (``Component.add_state_interfaces`` / ``add_command_interfaces``) is bound
   to the resource manager's buffers: its state values gathered into the input's array
   (``np.take(..., out=)``, two arrays in turn) just before the component's update, and
   the command it wrote scattered into the commands (``np.put``) just after, through a
   :class:`CommandGuard` made from the description's joint limits (non-finite refused
   and the previous command held, clamped to the limits, counted);
3. one **write** step: ``write_all``.

A hardware's read or write that raises or returns ERROR is handled by the resource
manager as ros2_control does; here it is logged with the hardware's name through the
runner's log ring, and the controllers that use its interfaces are deactivated before
the next iteration (the loop's feeder). Activation claims a controller's command keys
(:meth:`HardwareLoop.claim`, refused in ros2_control's words); every way out of active
releases them. The hardware is shut down with the runner.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any, cast

import numpy as np

from ._command_limits import CommandGuard, Counters, JointLimits
from ._errors import ConfigurationError
from ._hardware import ReturnType
from ._interface_claims import ClaimError, InterfaceClaims
from ._interface_ports import COMMAND, HardwareKeys, required_interfaces
from ._lifecycle import (
    ACTIVE,
    FAILURE,
    STATE_LABELS,
    SUCCESS,
    UNKNOWN,
    TransitionOutcome,
    refused,
)
from ._log import ComponentLogger, LogLevel, RecordSink
from ._loop_state import LoopState
from ._ports import OutputPort
from ._resource_manager import ReadWriteStatus, ResourceManager
from ._robot_description import parse
from ._settings import RunnerSettings

_OK = ReturnType.OK
HARDWARE_PREFIX = "@hardware/"  # a hardware's name in lifecycle requests and outcomes
READ_LABEL = "@hardware.read"  # the schedule's two steps (timing columns)
WRITE_LABEL = "@hardware.write"


class HardwareLogger(ComponentLogger):
    """The resource manager's and each hardware's logger: records into the runner's log
    ring (never Python's ``logging`` in the worker), with Python's Logger calls that
    hardware code uses (``getChild``, ``critical``, ``exception``, ``isEnabledFor``)."""

    __slots__ = ()

    def getChild(self, suffix: str) -> HardwareLogger:
        return HardwareLogger(f"{self.name}/{suffix}", self._ring, self._state, self.level)

    def critical(self, msg: str, *args: Any) -> None:
        self.fatal(msg, *args)

    def exception(self, msg: str, *args: Any) -> None:
        self.error(msg, *args)

    def isEnabledFor(self, level: int) -> bool:
        return level >= self.level


def description_of(settings: RunnerSettings) -> tuple[str, str] | None:
    """The runner's robot description as (text, where it came from), or None.

    The seam where the launch layer's description joins (``deployment.robot_description``
    sets ``settings.robot_description``); until then the runner's parameters give it."""
    if settings.robot_description:
        return settings.robot_description, "the runner's parameter robot_description"
    path = settings.robot_description_file
    if not path:
        return None
    try:
        with open(os.path.expanduser(path), encoding="utf-8") as f:
            return f.read(), path
    except OSError as exc:
        raise ConfigurationError(
            f"robot_description_file {path!r}: cannot read it ({exc.strerror}); give the "
            "path of the robot's URDF") from None


class InfiniteCommand(Exception):
    """A controller wrote an infinite command to hardware interfaces: refused (the
    previous one held), and the controller's fault (its on_error policy applies)."""


class _Gather:
    """Before an update: the state values into an input's array (two, in turn)."""

    __slots__ = ("_a", "_b", "_flip", "_idx", "_places", "_states", "_sub", "writer")

    def __init__(self, states: np.ndarray, idx: np.ndarray, places: np.ndarray | None,
                 n: int, writer: Any) -> None:
        self._states = states
        self._idx = idx
        self._places = places  # where the keys that exist go (None: every place)
        self._sub = np.empty(len(idx))
        self._a = np.full(n, np.nan)
        self._b = np.full(n, np.nan)
        self._flip = False
        self.writer = writer  # an output whose slot the input shares

    def __call__(self) -> None:
        flip = self._flip = not self._flip
        buf = self._a if flip else self._b
        if self._places is None:
            np.take(self._states, self._idx, out=buf)
        else:
            np.take(self._states, self._idx, out=self._sub)
            np.put(buf, self._places, self._sub)
        self.writer.write(buf)


class _Scatter:
    """After an update: the command it wrote (checked) into the commands."""

    __slots__ = ("_commands", "_idx", "_seen", "_slot", "guard", "infinite")

    def __init__(self, commands: np.ndarray, idx: np.ndarray, port: Any,
                 guard: CommandGuard) -> None:
        self._commands = commands
        self._idx = idx
        self._slot = port._slot
        self._seen = self._slot.seq
        self.guard = guard
        self.infinite = guard.infinite

    def __call__(self) -> bool:
        """True when the command was infinite (refused: the writer's fault)."""
        slot = self._slot
        if slot.seq == self._seen:
            return False
        self._seen = slot.seq
        guard = self.guard
        guard()
        value = slot.value  # checked: the command, clamped, or the one held (None: none)
        if value is not None:
            np.put(self._commands, self._idx, value)
        if guard.infinite != self.infinite:
            self.infinite = guard.infinite
            return True
        return False


class Bound:
    """A component's step with its hardware interfaces: gathers, its step, scatters."""

    __slots__ = ("component", "gathers", "scatters", "step")

    def __init__(self, component: str, step: Callable[[], object],
                 gathers: Sequence[_Gather], scatters: Sequence[_Scatter]) -> None:
        self.component = component
        self.step = step
        self.gathers = tuple(g.__call__ for g in gathers)
        self.scatters = tuple(scatters)

    def __call__(self) -> None:
        for gather in self.gathers:
            gather()
        self.step()
        fault = None
        for scatter in self.scatters:
            if scatter():
                fault = scatter
        if fault is not None:
            guard = fault.guard
            raise InfiniteCommand(
                f"wrote an infinite {guard.interface} command to {', '.join(guard.joints)} "
                f"({guard.port.name}); refused, the previous command was held")


class HardwareLoop:
    """A runner's hardware: the resource manager and what binds it into the schedule."""

    def __init__(self, rm: ResourceManager, state: LoopState, logger: HardwareLogger) -> None:
        self.rm = rm
        self.log = logger
        self._state = state
        self.keys = HardwareKeys(rm.state_keys, rm.command_keys)
        # the description's joint limits, for the commands' guards
        self.limits: dict[str, JointLimits] = {}
        for component in rm.components.values():
            for joint, lim in component.info.limits.items():
                known = self.limits.get(joint)
                self.limits[joint] = lim if known is None else known.tightened(lim)
        self.guards: dict[tuple[str, str], CommandGuard] = {}
        self._writers: dict[tuple[str, str], Any] = {}
        self._claimed: dict[str, tuple[str, ...]] = {}  # active controller -> its keys
        self._pending: list[str] = []  # hardware that failed in the last read or write
        self.deactivate: Callable[[str], object] | None = None  # a controller, by name
        # told of each hardware's change of state (a worker tells its supervisor)
        self.announce: Callable[[str, TransitionOutcome], None] | None = None
        self._period = 1.0 / state.frequency

    @classmethod
    def from_settings(cls, settings: RunnerSettings, state: LoopState, ring: RecordSink,
                      runner: str, *, offline: bool = False) -> HardwareLoop | None:
        """The hardware of the runner's robot description (None: it has none).
        ``offline``: plugins loaded and ``on_init`` only, nothing configured or
        activated (no bus opened, no device touched: ``rtcf check``, ``rtcf graph``)."""
        found = description_of(settings)
        if found is None:
            return None
        text, where = found
        logger = HardwareLogger(f"/{runner.strip('/')}/resource_manager", ring, state,
                                LogLevel.INFO)
        rm = ResourceManager(parse(text, where), max(1, round(settings.frequency)),
                             logger=logger)
        if not offline:
            rm.set_initial_states(settings.hardware_initial_unconfigured,
                                  settings.hardware_initial_inactive)
        return cls(rm, state, logger)

    # ------------------------------------------------------------- the loop's steps

    def read(self) -> None:
        """The schedule's first step: every hardware's read."""
        status = self.rm.read_all(self._state.time_ns * 1e-9, self._period)
        if status.result is not _OK:
            self._failed("read", status)

    def write(self) -> None:
        """The schedule's last step: every active hardware's write."""
        status = self.rm.write_all(self._state.time_ns * 1e-9, self._period)
        if status.result is not _OK:
            self._failed("write", status)

    def _failed(self, what: str, status: ReadWriteStatus) -> None:
        for name in status.failed_hardware_names:
            now = self.rm.components[name].state
            if self.announce is not None:  # (a failure's path: allocations are fine)
                self.announce(HARDWARE_PREFIX + name, TransitionOutcome(
                    0, ACTIVE, now, SUCCESS, "", f"its {what} failed"))
            self.log.error(
                "hardware '%s': its %s returned %s; it is %s now, and the controllers using "
                "its interfaces are deactivated (set_hardware_component_state brings it back)",
                name, what, status.result.name, _label(now))
            self._pending.append(name)

    def feeder(self) -> None:
        """At an iteration's start: deactivate the controllers that use a hardware that
        failed in the last iteration (as the controller manager does)."""
        if not self._pending:
            return
        failed, self._pending = set(self._pending), []
        for controller in self.users_of(failed):
            if self.deactivate is not None:
                self.deactivate(controller)

    def users_of(self, hardware: set[str]) -> list[str]:
        """The active controllers with an interface of ``hardware``."""
        owner = self.rm.hardware_of
        return [c for c, keys in self._claimed.items() if any(owner(k) in hardware for k in keys)]

    # ------------------------------------------------------------- binding

    def bind(self, component: Any, step: Callable[[], object],
             counters: Counters) -> Callable[[], object]:
        """``component``'s step with its bound ports' gathers and scatters."""
        rm = self.rm
        gathers: list[_Gather] = []
        scatters: list[_Scatter] = []
        for name, ports in component._rtcf_interfaces.items():
            port = ports.port
            if name not in component._rtcf_bound:
                continue
            keys = ports.keys
            if ports.kind == COMMAND:
                if not all(k in rm.command_index for k in keys):
                    continue  # its activation is refused (the keys are named there)
                guard = self._guard(component, port, keys)
                guard.prepare(component.period, counters)
                scatters.append(_Scatter(rm.commands, rm.command_indices(keys), port, guard))
                continue
            present = [i for i, k in enumerate(keys) if k in rm.state_index]
            if len(present) != len([k for k in keys if k]):
                continue  # a key no hardware exports: activation refuses it
            idx = rm.state_indices([keys[i] for i in present])
            places = None if len(present) == len(keys) else np.array(present, dtype=np.intp)
            writer = self._writer(component, port)
            gathers.append(_Gather(rm.states, idx, places, len(keys), writer))
        if not gathers and not scatters:
            return step
        return Bound(component.full_name, step, gathers, scatters)

    def _writer(self, component: Any, port: Any) -> Any:
        """The stand-in output a bound input is connected to (kept: its slot stays)."""
        key = (component.full_name, port.name)
        writer = self._writers.get(key)
        if writer is None:
            writer = self._writers[key] = OutputPort(
                "@hardware", port.name, port.type, component._rtcf_state)
            writer.topic = port.topic
        if port.producer is not writer:
            port._connect(writer)
        return writer

    def _guard(self, component: Any, port: Any, keys: Sequence[str]) -> CommandGuard:
        key = (component.full_name, port.name)
        guard = self.guards.get(key)
        if guard is None or guard.port is not port:
            joints = [k.rpartition("/")[0] for k in keys]
            interfaces = [k.rpartition("/")[2] for k in keys]
            limits = [self.limits.get(j, JointLimits()) for j in joints]
            guard = self.guards[key] = CommandGuard(component, port, interfaces, joints, limits)
        return guard

    # ------------------------------------------------------------- claims

    def claim(self, name: str, component: Any) -> str:
        """Claim ``component``'s command keys for its activation: "" if done, else why
        not (ros2_control's words, one line)."""
        if not component._rtcf_bound:
            return ""
        commands, states = required_interfaces(component)
        try:
            self.rm.claims.claim(controller_name(name), commands, states)
        except ClaimError as exc:
            return str(exc)
        self._claimed[name] = (*commands, *states)
        for key, guard in self.guards.items():
            if key[0] == name:
                guard.reset()
        return ""

    def preflight(self, controllers: Iterable[tuple[str, Any, bool]]) -> list[str]:
        """What the controller manager would refuse, before anything runs (``rtcf
        check``): each of ``controllers`` (name, component, whether it starts active)
        naming an interface no hardware exports, and the interfaces two that start
        active would both claim. ros2_control's words, one line each."""
        # whether each interface exists, whatever its hardware's state (offline: none
        # is configured), in the claims' own words
        claims = InterfaceClaims(cast(ResourceManager, _Exported(self.rm)), True, self.log)
        problems: list[str] = []
        starting: dict[str, list[str]] = {}
        reading: dict[str, list[str]] = {}
        for name, component, autostart in controllers:
            if not component._rtcf_bound:
                continue
            commands, states = required_interfaces(component)
            controller = controller_name(name)
            why = claims.check({controller: commands}, state_interfaces={controller: states})
            if why:
                problems.append(why)
            elif autostart:
                starting[controller], reading[controller] = commands, states
        why = claims.check(starting, state_interfaces=reading)
        if why:
            problems.append(why)
        return problems

    def release(self, name: str) -> None:
        """``name`` is no longer active: its claims go."""
        if self._claimed.pop(name, None) is not None:
            try:
                self.rm.claims.release(controller_name(name))
            except ClaimError as exc:
                self.log.error("releasing the claims of '%s': %s", name, exc)

    def claimed_interfaces(self, name: str) -> list[str]:
        return list(self.rm.claims.claimed_interfaces(controller_name(name)))

    # ------------------------------------------------------------- for the supervisor

    def transition(self, name: str, target: str) -> TransitionOutcome:
        """``set_hardware_component_state`` of ``@hardware/<hardware>`` to ``target`` (a
        lifecycle_msgs/State id or label), between iterations; announced."""
        hardware = name.removeprefix(HARDWARE_PREFIX)
        component = self.rm.components.get(hardware)
        if component is None:
            known = ", ".join(self.rm.components) or "none"
            return refused(UNKNOWN, f"hardware component '{hardware}' does not exist "
                                    f"(the description has: {known})")
        before = component.state
        ok, now = self.rm.set_hardware_component_state(
            hardware, int(target) if target.isdigit() else target)
        outcome = TransitionOutcome(0, before, now.id, SUCCESS if ok else FAILURE, "",
                                    "" if ok else f"could not reach {target!r}")
        if self.announce is not None:
            self.announce(name, outcome)
        return outcome

    def summary(self) -> list[dict[str, Any]]:
        """What the supervisor knows of the hardware: ``list_hardware_components``'
        fields, each interface as (name, data type), the state as an id."""
        return [{
            "name": c.name, "type": c.type, "is_async": c.is_async, "rw_rate": c.rw_rate,
            "plugin_name": c.plugin_name, "state": c.state.id,
            "command_interfaces": [(i.name, i.data_type) for i in c.command_interfaces],
            "state_interfaces": [(i.name, i.data_type) for i in c.state_interfaces],
        } for c in self.rm.list_hardware_components()]

    # ------------------------------------------------------------- the end

    def shutdown(self) -> None:
        """Every hardware to finalized (the runner's teardown)."""
        self._claimed.clear()
        self.rm.shutdown_components()


class _Exported:
    """A resource manager as seen offline: an interface is available if it exists."""

    def __init__(self, rm: ResourceManager) -> None:
        self._rm = rm
        self.command_interface_is_available = rm.command_interface_exists
        self.state_interface_is_available = rm.state_interface_exists

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rm, name)


def controller_name(component: str) -> str:
    """What a claim calls a component: its name as ros2_control's tools give it (no
    leading slash)."""
    return component.lstrip("/")


def _label(state: int) -> str:
    return STATE_LABELS.get(state, str(state))
