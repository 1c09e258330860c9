"""Faults: what the loop does when a component fails or the timing goes wrong.

A component's failure policy (launcher parameter ``on_error``) says what happens when
its ``update`` raises:

* ``stop`` (default): the loop ends after the failed iteration, every active
  component's ``safe_stop`` runs (last in the order first), and the run fails;
* ``deactivate``: the component and every component downstream of it in the data
  flow (feedback connections included: what reads its outputs, directly or not)
  leave the schedule between two iterations; their ``safe_stop`` runs; the others
  go on, on the same time grid;
* ``restart``: the component is cleaned up, configured and started again between
  two iterations, at most ``max_restarts`` times in a run; then it is deactivated.

``fallback:=NAME`` names a component, loaded inactive, that takes over the failed
one's outputs: it is activated in the failed one's place (after ``deactivate``, or
when ``restart`` gives up), and what reads those outputs goes on.

The failed iteration ends at the failure (what comes after the failed component in
the order runs again from the next iteration, on the same grid) and has no timing
row. ``SystemExit`` and ``KeyboardInterrupt`` raised by an update always stop the
loop.

``on_deadline`` (``continue``, ``deactivate`` or ``stop``) is what the loop does when
one of its inputs passes its deadline (``deadline/NAME``, seconds; see
:mod:`rtcf._core._deadlines`); ``deactivate`` and ``stop`` act as for ``on_error``.

Watchdogs (runner parameters) end the loop through the same safe-stop path:
``max_consecutive_overruns`` and ``max_overruns_per_second`` (0: off), and for a lane on
logical execution time ``max_let_overruns`` (windows it did not finish in a run).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from ._errors import ConfigurationError

STOP = "stop"
DEACTIVATE = "deactivate"
RESTART = "restart"
POLICIES = (STOP, DEACTIVATE, RESTART)
DEFAULT_MAX_RESTARTS = 3
# what a Fault contained: an update that raised, or a LET lane's windows that overran
RAISED, LET_OVERRUNS = "raised", "let_overruns"
# on_deadline: an input past its deadline (rtcf._core._deadlines)
DEADLINE_CONTINUE, DEADLINE_DEACTIVATE, DEADLINE_STOP = "continue", "deactivate", "stop"
DEADLINE_POLICIES = (DEADLINE_CONTINUE, DEADLINE_DEACTIVATE, DEADLINE_STOP)


@dataclass(frozen=True)
class FailurePolicy:
    """What the loop does when one component's ``update`` raises."""

    on_error: str = STOP
    max_restarts: int = DEFAULT_MAX_RESTARTS
    fallback: str = ""  # full name of the component that takes over, or ""
    # an input past its deadline (rtcf._core._deadlines), and the launch file's deadlines
    on_deadline: str = DEADLINE_CONTINUE
    deadlines: tuple[tuple[str, float], ...] = ()  # (input name, seconds)

    def __post_init__(self) -> None:
        if self.on_error not in POLICIES:
            raise ConfigurationError(
                f"on_error must be one of {', '.join(POLICIES)}, not {self.on_error!r}"
            )
        if self.on_deadline not in DEADLINE_POLICIES:
            raise ConfigurationError(
                f"on_deadline must be one of {', '.join(DEADLINE_POLICIES)}, "
                f"not {self.on_deadline!r}"
            )
        if not isinstance(self.max_restarts, int) or self.max_restarts < 0:
            raise ConfigurationError(
                f"max_restarts must be a whole number >= 0, not {self.max_restarts!r}"
            )

    def apply_deadlines(self, inputs: Mapping[str, Any]) -> None:
        """Give ``inputs`` (name -> InputPort) the launch file's deadlines."""
        for name, _ in self.deadlines:
            if name not in inputs:
                raise ConfigurationError(
                    f"deadline/{name} names no input; its inputs: "
                    f"{', '.join(sorted(inputs)) or 'none'}"
                )
        for name, seconds in self.deadlines:
            inputs[name]._deadline_ns = deadline_ns(seconds, f"input {name!r}")

    @classmethod
    def from_params(cls, params: Mapping[str, Any], component: str) -> FailurePolicy:
        """The policy from a launcher's parameters (``on_error``, ``max_restarts``,
        ``fallback``, ``on_deadline``, ``deadline/NAME``); the error names the
        component."""
        fallback = str(params.get("fallback", "") or "")
        if fallback and not fallback.startswith("/"):  # relative to the component's namespace
            namespace = component.rpartition("/")[0]
            fallback = f"{namespace}/{fallback}"
        try:
            return cls(
                on_error=str(params.get("on_error", STOP)).strip().lower(),
                max_restarts=_whole(params.get("max_restarts", DEFAULT_MAX_RESTARTS)),
                fallback=fallback,
                on_deadline=str(params.get("on_deadline", DEADLINE_CONTINUE)).strip().lower(),
                deadlines=_deadlines(params),
            )
        except ConfigurationError as exc:
            raise ConfigurationError(f"component {component!r}: {exc.message}") from None


def deadline_ns(seconds: Any, where: str) -> int:
    """A deadline in seconds as nanoseconds, or ConfigurationError naming ``where``."""
    ok = isinstance(seconds, (int, float)) and not isinstance(seconds, bool)
    if isinstance(seconds, str):
        try:
            seconds, ok = float(seconds), True
        except ValueError:
            ok = False
    if not ok or not math.isfinite(seconds) or seconds <= 0:
        raise ConfigurationError(
            f"{where}: deadline {seconds!r} must be a positive number of seconds"
        )
    return max(1, round(float(seconds) * 1e9))


def _deadlines(params: Mapping[str, Any]) -> tuple[tuple[str, float], ...]:
    """``deadline/NAME`` parameters: a ``deadline`` subtree (launch XML's ``<param
    name="deadline/cmd_vel" .../>``), or flat keys (ROS 2's ``deadline.cmd_vel``)."""
    found: dict[str, Any] = {}
    tree = params.get("deadline")
    if isinstance(tree, Mapping):
        found.update(tree)
    elif tree is not None:
        raise ConfigurationError(
            f"deadline is {tree!r}; name the input: deadline/NAME (seconds)"
        )
    for key, value in params.items():
        for prefix in ("deadline/", "deadline."):
            if isinstance(key, str) and key.startswith(prefix):
                found[key[len(prefix):]] = value
    out = []
    for name, value in sorted(found.items()):
        ok = isinstance(value, (int, float, str)) and not isinstance(value, bool)
        try:
            seconds = float(value) if ok else math.nan
        except ValueError:
            seconds = math.nan
        if not math.isfinite(seconds) or seconds <= 0:
            raise ConfigurationError(
                f"deadline/{name} is {value!r}; it must be a positive number of seconds"
            )
        out.append((str(name), seconds))
    return tuple(out)


def _whole(value: Any) -> int:
    if isinstance(value, bool):
        return -1
    if isinstance(value, int):
        return value
    if isinstance(value, str) and value.strip().isdigit():
        return int(value)
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return -1


class WatchdogTripped(Exception):
    """A runner watchdog fired: ``limit`` (its parameter), the measured value, where."""

    def __init__(
        self, limit: str, allowed: int, measured: int, iteration: int, resume: int = -1
    ) -> None:
        super().__init__(limit, allowed, measured, iteration)
        self.limit = limit
        self.allowed = allowed
        self.measured = measured
        self.iteration = iteration
        # max_let_overruns: the iteration before the next release on the grid (where
        # the lane goes on if its components' on_error policy contains the overruns)
        self.resume = resume

    def describe(self) -> str:
        what = {
            "max_consecutive_overruns": f"{self.measured} overruns in a row",
            "max_overruns_per_second": f"{self.measured} overruns within one second",
            "max_let_overruns": f"{self.measured} windows of logical execution time "
            "not finished in time, the last released",
        }.get(self.limit, f"{self.measured}")
        return (
            f"watchdog {self.limit}={self.allowed}: {what} at iteration {self.iteration}; "
            "the loop was stopped"
        )


@dataclass
class Fault:
    """One contained failure, as timing.json and /diagnostics report it."""

    component: str
    iteration: int
    error: str
    action: str  # "deactivated", "restarted", "fallback"
    taken_out: list[str] = field(default_factory=list)
    fallback: str = ""
    cause: str = RAISED  # or LET_OVERRUNS: error is the watchdog's own words

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def describe(self) -> str:
        if self.cause == LET_OVERRUNS:  # its windows, not an exception
            text = f"component {self.component!r}: {self.error}; "
        else:
            text = f"component {self.component!r}: update() raised {self.error} at iteration "
            text += f"{self.iteration}; "
        if self.action == "restarted":
            return text + "restarted it (on_error restart)"
        out = ", ".join(self.taken_out)
        text += f"took out of the schedule: {out}" if out else "nothing to take out"
        if self.fallback:
            text += f"; {self.fallback} took over its outputs (fallback)"
        return text


def downstream(name: str, edges: Iterable[tuple[str, str]]) -> list[str]:
    """``name`` and every component that reads its outputs, directly or through others.

    ``edges`` are (producer, consumer) pairs of the data flow, feedback included.
    The result keeps ``name`` first, then the others in the order found.
    """
    readers: dict[str, list[str]] = {}
    for producer, consumer in edges:
        readers.setdefault(producer, []).append(consumer)
    seen = [name]
    queue = [name]
    while queue:
        for reader in readers.get(queue.pop(0), ()):
            if reader not in seen:
                seen.append(reader)
                queue.append(reader)
    return seen


@dataclass
class SafeStopOutcome:
    """How one component's ``safe_stop`` went: ``ok``, or what it raised/returned."""

    component: str
    ok: bool
    detail: str = ""

    def describe(self) -> str:
        return f"{self.component}: safe_stop() {'ran' if self.ok else self.detail}"
