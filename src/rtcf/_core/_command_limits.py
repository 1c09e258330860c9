"""Limits at the hardware's edge: the last check between a command and the hardware.

A hardware component declares each command interface it takes as a command input
(``Component.add_command_input``): one float64 array per command, a value per joint.
Before the component's ``update`` runs, each new command on such an input is checked
(:class:`CommandGuard`), in the loop, without allocating; its numbers (finite, the
bounds, the rate limit, the clamp) in one call of the hot path's ``CommandCheck``
(C on the compiled path, numpy in rtcf._core._interpreted):

* **Not finite, or not one float per joint**: never passed on (a float array of
  another dtype, float32 say, is checked and passed on as the guard's float64 copy).
  The previous command is held (the input reads it again; None before the first good
  one), as ros2_control's GenericSystem ignores a NaN command. An infinite value is
  also a fault of the component that wrote it: once the hardware's ``update`` has run
  on the held command, that component's ``on_error`` policy applies (stop, deactivate,
  restart, a fallback). A command fed from the middleware (nothing in the runner writes the
  topic) is only held.
* **Outside the limits**: clamped, as ros2_control's joint_limits saturation limiter
  does when enforcement is on: a position into ``[min_position, max_position]`` and
  within ``max_velocity`` times the period of the last command passed on, a velocity
  into ``+-max_velocity`` and within ``max_acceleration`` times the period of the last,
  an acceleration into ``+-max_acceleration``, an effort into ``+-max_effort``.

A clamped command is an array of the guard's own (two, in turn: a value read stays as
it is through the next iteration); the writer's array is left alone, so what was
recorded or published is what the controller commanded. Each clamp (per joint) and
refusal is counted: the status line, ``/diagnostics`` and timing.json say them
(``command_limits``); the log says the first of each kind and then at most one a
second per input, with how many came between.

Limits come from the hardware component itself, tightened by its launch file's
``joint_limits.<joint>.<field>`` parameters (ros2_control's joint_limits names). A
launch file cannot widen what the hardware declares.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable, Mapping, MutableSequence, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ._errors import ComponentError, ConfigurationError
from ._hotpath import CommandCheck
from ._ports import InputPort, OutputPort

# a component (rtcf._core._component imports this module): its params, log, time_ns
Component = Any

INF = math.inf
# which limits bound each interface's values, and which its change per period
# (ros2_control's saturation limiter); other interfaces: finite values only
BOUNDS: dict[str, tuple[str, str, str]] = {
    "position": ("min_position", "max_position", "max_velocity"),
    "velocity": ("-max_velocity", "max_velocity", "max_acceleration"),
    "acceleration": ("-max_acceleration", "max_acceleration", ""),
    "effort": ("-max_effort", "max_effort", ""),
}
_LOG_EVERY_NS = 1_000_000_000  # one record a second per input and kind, with a count


@dataclass(frozen=True)
class JointLimits:
    """One joint's limits, as ros2_control's ``joint_limits::JointLimits`` names them
    (infinite: no limit). Speeds and effort are magnitudes: ``max_velocity`` bounds
    ``-max_velocity .. max_velocity``."""

    min_position: float = -INF
    max_position: float = INF
    max_velocity: float = INF
    max_acceleration: float = INF
    max_effort: float = INF

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or math.isnan(value):
                raise ConfigurationError(f"JointLimits: {f.name} is {value!r}; give a number")
            object.__setattr__(self, f.name, float(value))
            if f.name.startswith("max_") and f.name != "max_position" and value <= 0:
                raise ConfigurationError(
                    f"JointLimits: {f.name} is {value!r}; give a magnitude above 0 "
                    "(inf: no limit)")
        if self.min_position > self.max_position:
            raise ConfigurationError(
                f"JointLimits: min_position {self.min_position:g} is above max_position "
                f"{self.max_position:g}")

    def tightened(self, other: JointLimits) -> JointLimits:
        """The narrower of the two, field by field."""
        return JointLimits(
            min_position=max(self.min_position, other.min_position),
            max_position=min(self.max_position, other.max_position),
            max_velocity=min(self.max_velocity, other.max_velocity),
            max_acceleration=min(self.max_acceleration, other.max_acceleration),
            max_effort=min(self.max_effort, other.max_effort),
        )

    def bounds(self, interface: str) -> tuple[float, float, float]:
        """(lowest, highest, largest change per second) of ``interface``'s commands."""
        lo, hi, rate = BOUNDS.get(interface, ("", "", ""))

        def value(name: str, default: float) -> float:
            if not name:
                return default
            if name.startswith("-"):
                return -float(getattr(self, name[1:]))
            return float(getattr(self, name))

        return value(lo, -INF), value(hi, INF), value(rate, INF)


class NonFiniteCommand(Exception):
    """An infinite command reached a hardware's command input: a fault of the component
    that wrote ``topic`` (the loop's containment applies that one's policy)."""

    def __init__(self, topic: str, hardware: str, text: str) -> None:
        super().__init__(text)
        self.topic = topic
        self.hardware = hardware


def launch_limits(component: Component, joint: str) -> JointLimits | None:
    """What ``component``'s launch file says of ``joint``: ``joint_limits.<joint>.*``
    (a YAML's nested keys or dotted ones), or None. ``has_<kind>_limits: false`` is
    no limit of its own (it cannot remove the component's)."""
    params = component.params
    given: dict[str, float] = {}
    for f in fields(JointLimits):
        for key in (f"~joint_limits/{joint}/{f.name}", f"~joint_limits.{joint}.{f.name}"):
            if params.has(key):
                value = params.get(key)
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise ConfigurationError(
                        f"component {component.full_name!r}: parameter "
                        f"joint_limits.{joint}.{f.name} is {value!r}; give a number")
                given[f.name] = float(value)
                break
    for kind, names in (("position", ("min_position", "max_position")),
                        ("velocity", ("max_velocity",)),
                        ("acceleration", ("max_acceleration",)), ("effort", ("max_effort",))):
        for key in (f"~joint_limits/{joint}/has_{kind}_limits",
                    f"~joint_limits.{joint}.has_{kind}_limits"):
            if params.has(key) and params.get(key) is False:
                for name in names:
                    given.pop(name, None)
    if not given:
        return None
    try:
        return JointLimits(**given)
    except ConfigurationError as exc:
        raise ConfigurationError(
            f"component {component.full_name!r}: parameters joint_limits.{joint}.*: "
            f"{str(exc).removeprefix('JointLimits: ')}") from None


class Counters:
    """A runner's totals of the commands its guards clamped and refused: cells of one
    integer each, which a worker replaces with words of its shared memory, so that the
    supervisor's status line reads them while the loop runs."""

    def __init__(self) -> None:
        self.clamped: MutableSequence[int] | memoryview = array("q", [0])
        self.refused: MutableSequence[int] | memoryview = array("q", [0])


class CommandGuard:
    """The check of one command input (see the module's docstring). Called before the
    hardware's update; True when it refused an infinite command that a component of
    the runner wrote."""

    __slots__ = (
        "_buffers", "_changed", "_check", "_component", "_counters", "_hi", "_last", "_lo",
        "_logged_ns", "_rate", "_rate_limited", "_shape", "_step", "_unsaid", "_which",
        "clamped", "infinite", "interface", "joints", "last", "limits", "malformed",
        "nan", "port", "seen",
    )

    def __init__(self, component: Component, port: InputPort[Any] | OutputPort[Any],
                 interface: str | Sequence[str], joints: Sequence[str],
                 limits: Sequence[JointLimits]) -> None:
        n = len(joints)
        self._component = component
        self.port = port  # a command input, or a controller's output of hardware commands
        # one interface for every joint, or one each (a port of hardware interfaces)
        each = [interface] * n if isinstance(interface, str) else list(interface)
        self.interface = interface if isinstance(interface, str) else "/".join(
            dict.fromkeys(each))
        self.joints = tuple(joints)
        self.limits = tuple(limits)
        bounds = [lim.bounds(i) for lim, i in zip(limits, each, strict=True)]
        self._lo = np.array([b[0] for b in bounds], dtype=float)
        self._hi = np.array([b[1] for b in bounds], dtype=float)
        self._rate = np.array([b[2] for b in bounds], dtype=float)
        self._step = np.full(n, INF)  # the rate times the period: set by prepare()
        self._rate_limited = bool(np.isfinite(self._rate).any())
        self._buffers = (np.zeros(n), np.zeros(n))
        self._which = 0
        self._shape = (n,)
        self._changed = np.zeros(n, dtype=bool)
        self._last = np.zeros(n)  # the check's copy of the last command passed on
        # the numbers in one call (C on the compiled path): it holds the arrays, and
        # reads step as prepare() sets it
        self._check = CommandCheck(self._lo, self._hi, self._step, self._last, self._changed)
        self._counters = Counters()
        self.clamped = np.zeros(n, dtype=np.int64)  # commands clamped, per joint
        self.nan = 0  # refused, and the previous command held: not a number
        self.infinite = 0  # ... infinite (the writer's fault)
        self.malformed = 0  # ... not an array of one float per joint
        self.last: np.ndarray | None = None  # the last command passed on
        self.seen = 0  # the slot's seq at the last check
        self._logged_ns = [-_LOG_EVERY_NS] * 4  # when each kind was last logged
        self._unsaid = [0] * 4  # how many of each kind since

    def prepare(self, period_s: float, counters: Counters) -> None:
        """Before the loop runs: the component's period (the limits on a change per
        period) and the runner's totals."""
        np.multiply(self._rate, period_s, out=self._step)
        self._counters = counters

    def adopt(self, old: CommandGuard) -> None:
        """Configured again: carry on ``old``'s counts."""
        self.clamped[:] = old.clamped
        self.nan, self.infinite, self.malformed = old.nan, old.infinite, old.malformed
        self.seen = old.seen

    @property
    def refused(self) -> int:
        return self.nan + self.infinite + self.malformed

    def reset(self) -> None:
        """The hardware starts again: no last command to hold or to change from."""
        self.last = None

    def __call__(self) -> bool:
        slot = self.port._slot
        seq = slot.seq
        if seq == self.seen:  # nothing new: the last check stands
            return False
        self.seen = seq
        value = slot.value
        if type(value) is not np.ndarray:
            self.malformed += 1
            self._hold(slot, 0, value)
            return False
        out = self._buffers[self._which]
        last = self.last
        rate_limited = last is not None and self._rate_limited
        # finite, then within [lo, hi] (and a period's change of the last): in one call
        code = self._check(value, out, rate_limited)
        if code == 0:  # passed on unchanged
            self.last = value
            return False
        given = value
        if code == 4:  # not native float64 (or not n): another float as float64, or refused
            if value.dtype.kind != "f" or value.shape != self._shape:
                self.malformed += 1
                self._hold(slot, 0, value)
                return False
            np.copyto(out, value)  # float32, a byte-swapped float64, ...: the guard's copy
            code = self._check(out, out, rate_limited)
            if code == 0:
                self._which ^= 1
                slot.value = self.last = out
                return False
        if code == 1:  # clamped into out
            self._which ^= 1
            np.add(self.clamped, self._changed, out=self.clamped, casting="unsafe")
            self._counters.clamped[0] += 1
            self._say(3, given)
            slot.value = self.last = out
            return False
        infinite = code == 3  # refused: not finite
        if infinite:
            self.infinite += 1
        else:
            self.nan += 1
        self._hold(slot, 2 if infinite else 1, given)
        # the writer is known: a component of the runner (an output's is its own)
        return infinite and getattr(self.port, "producer", self.port) is not None

    def _hold(self, slot: Any, kind: int, value: Any) -> None:
        slot.value = self.last  # the previous command again (None: there was none)
        self._counters.refused[0] += 1
        self._say(kind, value)

    def _say(self, kind: int, value: Any) -> None:
        now = self._component.time_ns
        if 0 <= now - self._logged_ns[kind] < _LOG_EVERY_NS:
            self._unsaid[kind] += 1  # said with the next record of its kind
            return
        self._logged_ns[kind] = now
        unsaid, self._unsaid[kind] = self._unsaid[kind], 0
        more = f" ({unsaid} more like it since the last record)" if unsaid else ""
        self._component.log.warning("%s%s", self.describe(kind, value), more)

    def describe(self, kind: int, value: Any) -> str:
        """The log line of one clamp or refusal (outside the steady state: it formats)."""
        port, joints = self.port, self.joints
        where = f"{port.name} ({port.topic})"
        if kind == 0:
            shape = getattr(value, "shape", None)
            what = (f"{type(value).__name__} of shape {shape}" if shape is not None
                    else type(value).__name__)
            return (f"{where}: command refused, a {what} is not {len(joints)} floats "
                    f"({', '.join(joints)}); the previous command is held")
        if kind in (1, 2):
            bad = [f"{j} {float(v)}" for j, v in zip(joints, value, strict=True)
                   if not math.isfinite(v)]
            whose = "" if kind == 1 or getattr(port, "producer", port) is None else (
                "; a fault of the component that wrote it")
            return (f"{where}: {self.interface} command refused, not finite ({', '.join(bad)})"
                    f"; the previous command is held{whose}")
        out = self._buffers[self._which ^ 1]  # the clamped command (written last)
        clamped = [f"{j} {float(v):g} to {float(o):g}" for j, v, o, c in
                   zip(joints, value, out, self._changed, strict=True) if c]
        return f"{where}: {self.interface} command clamped to its limits ({', '.join(clamped)})"

    def summary(self) -> dict[str, Any]:
        """What timing.json says of this input."""
        return {
            "topic": self.port.topic,
            "interface": self.interface,
            "joints": list(self.joints),
            "clamped": {j: int(c) for j, c in zip(self.joints, self.clamped, strict=True)},
            "refused_not_a_number": self.nan,
            "refused_infinite": self.infinite,
            "refused_malformed": self.malformed,
        }


def describe_summary(name: str, summary: dict[str, Any]) -> str:
    """The end-of-run line of one command input (:meth:`CommandGuard.summary`), or ""
    when its limits never acted."""
    clamped = [f"{j} {n} time{'s' * (n != 1)}" for j, n in summary["clamped"].items() if n]
    refused = [f"{summary[key]} {what}" for key, what in (
        ("refused_not_a_number", "not a number"), ("refused_infinite", "infinite"),
        ("refused_malformed", "not one float per joint")) if summary[key]]
    if not clamped and not refused:
        return ""
    parts = ([f"clamped {', '.join(clamped)}"] if clamped else []) + (
        [f"refused {', '.join(refused)} (the previous command held)"] if refused else [])
    return (f"limits: command input {name!r} ({summary['topic']}, "
            f"{summary['interface']}): {'; '.join(parts)}")


class Guarded:
    """A hardware component's step in the plan: its command inputs' guards, its update,
    then, if a guard refused an infinite command, the writer's fault."""

    __slots__ = ("guards", "hardware", "update")

    def __init__(self, hardware: str, update: Callable[[], object],
                 guards: Sequence[CommandGuard]) -> None:
        self.hardware = hardware
        self.update = update
        self.guards = tuple(guards)

    def __call__(self) -> None:
        fault = None
        for guard in self.guards:
            if guard():
                fault = guard
        self.update()
        if fault is not None:
            raise NonFiniteCommand(
                fault.port.topic, self.hardware,
                f"wrote an infinite {fault.interface} command to {fault.port.topic}, which "
                f"{self.hardware} refused (the previous command was held)")


def resolve_limits(component: Component, joints: Sequence[str],
                   limits: Mapping[str, JointLimits] | Sequence[JointLimits] | None
                   ) -> list[JointLimits]:
    """One JointLimits per joint: the component's own, tightened by its launch file."""
    if limits is None:
        own = [JointLimits()] * len(joints)
    elif isinstance(limits, Mapping):
        unknown = sorted(set(limits) - set(joints))
        if unknown:
            raise ConfigurationError(
                f"component {component.full_name!r}: limits for {unknown}, which are not "
                f"among its joints {list(joints)}")
        own = [limits.get(j, JointLimits()) for j in joints]
    else:
        own = list(limits)
        if len(own) != len(joints):
            raise ConfigurationError(
                f"component {component.full_name!r}: {len(own)} limits for "
                f"{len(joints)} joints; give one JointLimits per joint")
    out = []
    for joint, lim in zip(joints, own, strict=True):
        if not isinstance(lim, JointLimits):
            raise ConfigurationError(
                f"component {component.full_name!r}: the limits of {joint!r} are {lim!r}; "
                "give an rtcf.JointLimits")
        given = launch_limits(component, joint)
        out.append(lim if given is None else lim.tightened(given))
    return out


def declare_command_input(
    component: Component, name: str, interface: str, joints: Sequence[str],
    limits: Mapping[str, JointLimits] | Sequence[JointLimits] | None, deadline: float | None,
) -> InputPort[Any]:
    """``Component.add_command_input``: the port, and its guard in the component's
    ``_rtcf_guards`` (configured again: a new guard, with the old one's counts)."""
    joints = [str(j) for j in joints]
    if not joints or len(set(joints)) != len(joints):
        raise ComponentError(
            f"component {component.full_name!r}: command input {name!r} has joints "
            f"{joints}; give one name per joint, each once", component=component.full_name)
    port: InputPort[Any] = component.add_input(name, np.ndarray, deadline=deadline)
    guard = CommandGuard(component, port, interface, joints,
                         resolve_limits(component, joints, limits))
    old = component._rtcf_guards.get(name)
    if old is not None and old.port is port and old.joints == guard.joints:
        guard.adopt(old)
    component._rtcf_guards[name] = guard
    return port
