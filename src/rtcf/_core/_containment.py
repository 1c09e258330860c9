"""Fault containment and safe stops: what the loop does when a component fails.

When an update raises (or a LET lane overruns more windows than it may), the failed
component's policy (:mod:`rtcf._core._faults`) applies between two iterations:
``stop`` ends the loop after every active component's ``safe_stop``; ``deactivate``
takes it and what reads its outputs out of the schedule (a fallback takes over);
``restart`` runs its lifecycle transitions again. Each contained failure is recorded
as a :class:`Fault`; each safe stop's outcome as a :class:`SafeStopOutcome`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from ._chaining import chained_first
from ._command_limits import NonFiniteCommand
from ._component import overrides
from ._components import Components
from ._errors import ComponentError, LoopError
from ._executor import UpdateFailure
from ._faults import DEACTIVATE as ON_ERROR_DEACTIVATE
from ._faults import (
    LET_OVERRUNS,
    RAISED,
    FailurePolicy,
    Fault,
    SafeStopOutcome,
    WatchdogTripped,
    downstream,
)
from ._faults import RESTART as ON_ERROR_RESTART
from ._lifecycle import ACTIVE, DEACTIVATE, INACTIVE, SUCCESS, TransitionOutcome
from ._log import LogLevel
from ._loop_state import LoopState
from ._notices import Notices
from ._schedule import Schedule
from ._topology import Topology
from ._transitions import Transitions


class _LetOverruns(Exception):
    """What a LET lane's component "raised": its windows overran (max_let_overruns)."""


class Containment:
    """Applies the failure policies, runs the safe stops, and keeps what they did."""

    def __init__(
        self,
        name: str,
        components: Components,
        topology: Topology,
        schedule: Schedule,
        transitions: Transitions,
        state: LoopState,
        notices: Notices,
    ) -> None:
        self._name = name  # the runner's, for its messages
        self._components = components
        self._topology = topology
        self._schedule = schedule
        self._transitions = transitions
        self._state = state
        self._notices = notices
        self.faults: list[Fault] = []  # contained failures of this runner's life
        self.on_fault: Callable[[Fault], None] | None = None  # a worker counts them
        self.safe_stops: list[SafeStopOutcome] = []  # of the last safe stop
        # components an input's deadline took out, and what went with each
        self._deadline_taken: dict[str, list[str]] = {}

    def contain(self, failure: UpdateFailure) -> None:
        """Apply the failed component's policy; raise ComponentError if the loop ends."""
        self._notices.drain()
        name = self._schedule.labels[failure.index]
        entry = self._components.entries.get(name)
        if entry is None:  # a lane's handover, not a component: a bug or bad data
            self.safe_stop(f"the lane handover {name!r} failed")
            exc = failure.error
            raise LoopError(
                f"runner {self._name!r}: lane handover {name!r} raised {type(exc).__name__}: "
                f"{exc} at iteration {failure.iteration}; the loop was stopped"
            ) from exc
        exc = failure.error
        if isinstance(exc, NonFiniteCommand):  # the hardware refused what another wrote
            writer = self._writer_of(exc.topic, name)
            if writer is None:  # written in another lane: held, counted and said there
                return
            name, entry = writer, self._components.entries[writer]
        cause = LET_OVERRUNS if isinstance(exc, _LetOverruns) else RAISED
        error = (
            str(exc) if cause == LET_OVERRUNS
            else type(exc).__name__ + (f": {exc}" if str(exc) else "")
        )
        policy = entry.spec.policy
        fatal = not isinstance(exc, Exception)  # SystemExit, KeyboardInterrupt: always stop
        if fatal or policy.on_error not in (ON_ERROR_DEACTIVATE, ON_ERROR_RESTART):
            self.safe_stop(f"component {name!r} failed")
            did = str(exc) if isinstance(exc, NonFiniteCommand) else f"update() raised {error}"
            raise ComponentError(
                f"component {name!r}: {did} "
                f"at iteration {failure.iteration} (t={failure.time_ns * 1e-9:.6f} s); "
                "the loop was stopped",
                component=name,
            ) from exc
        if policy.on_error == ON_ERROR_RESTART and entry.restarts < policy.max_restarts:
            entry.restarts += 1
            if self._restart(name):
                self._record(Fault(name, failure.iteration, error, "restarted", cause=cause))
                return
        self._take_out(name, failure.iteration, error, policy, cause)

    def _writer_of(self, topic: str, hardware: str) -> str | None:
        """The active component of this process that writes ``topic`` (a claimed
        command's active claimant, or a fallback in its primary's place), or None."""
        for name, entry in self._components.entries.items():
            if name != hardware and entry.state == ACTIVE and any(
                    p.topic == topic for p in entry.component._rtcf_outputs.values()):
                return name
        return None

    def contain_let_overruns(self, trip: WatchdogTripped) -> bool:
        """A lane on logical execution time overran more windows than
        ``max_let_overruns``: its active components' ``on_error`` policies apply, as if
        their update had failed (deactivate: out of the schedule, a fallback in the
        lane takes over; restart). False when one of them stops the loop."""
        if trip.limit != "max_let_overruns":
            return False
        loaded = self._components.entries
        labels = self._schedule.labels
        names = [n for n in labels if n in loaded and loaded[n].state == ACTIVE]
        policies = {loaded[n].spec.policy.on_error for n in names}
        if not names or not policies <= {ON_ERROR_DEACTIVATE, ON_ERROR_RESTART}:
            return False
        self._state.iteration = trip.resume  # on the grid again: the next release
        what = trip.describe().replace("; the loop was stopped", "")
        for name in names:
            if loaded[name].state != ACTIVE:  # taken out with another one
                continue
            self.contain(UpdateFailure(
                self._schedule.labels.index(name), trip.iteration, self._state.time_ns,
                _LetOverruns(what),
            ))
        return True

    def safe_stop(self, reason: str = "") -> list[SafeStopOutcome]:
        """Run every active component's ``safe_stop``, last in the order first (see
        :meth:`Runner.safe_stop`)."""
        loaded = self._components.entries
        order = self._topology.stopping_order()
        names = [n for n in reversed(order) if n in loaded and loaded[n].state == ACTIVE]
        if reason:
            self._notices.log(LogLevel.WARNING, self._name, f"safe stop: {reason}")
        return self._run_safe_stops(names)

    def _restart(self, name: str) -> bool:
        """Clean up, configure and start a component again (lifecycle transitions)."""
        for transition in ("deactivate", "cleanup", "configure", "activate"):
            if not self._transitions.change(name, transition).ok:
                return False
        return True

    def take_out_for_deadline(self, name: str, iteration: int, why: str) -> str:
        """``on_deadline: deactivate``: as ``on_error: deactivate``, in the iteration that
        begins (called between the feeders and the first update). Returns the fallback
        that took over, or ""."""
        policy = self._components.entries[name].spec.policy
        fallback, taken = self._take_out(name, iteration, why, policy, "", record=False)
        self._deadline_taken[name] = taken
        return fallback

    def bring_back(self, name: str, fallback: str) -> None:
        """An input of ``name`` that passed its deadline has a value again: its fallback
        stands by again, and what its deadline took out comes back as ``activate``
        brings it back (in the execution order)."""
        loaded = self._components.entries
        if fallback in loaded and loaded[fallback].state == ACTIVE:
            self._transitions.change(fallback, "deactivate")
        order = self._topology.graph.order
        back = sorted(self._deadline_taken.pop(name, [name]), key=order.index)
        if self._transitions.hardware is not None:  # chained controllers before theirs
            back = chained_first(back, {n: loaded[n].component for n in back if n in loaded})
        for n in back:
            if n in loaded and loaded[n].state == INACTIVE:
                loaded[n].autostart = True
                self._transitions.change(n, "activate")
        self._notices.drain()

    def _take_out(
        self, name: str, iteration: int, error: str, policy: FailurePolicy, cause: str,
        record: bool = True,
    ) -> tuple[str, list[str]]:
        """Take ``name`` and what reads its outputs out of the schedule; safe-stop them.
        Returns the fallback that took over ("" if none) and what was taken out."""
        loaded = self._components.entries
        graph = self._topology.graph
        edges = [(e.producer.component, e.consumer.component) for e in graph.edges]
        order = graph.order
        fallback = policy.fallback if policy.fallback in loaded else ""
        if fallback and loaded[fallback].state != INACTIVE:
            fallback = ""  # not ready to take over (failed itself, or unconfigured)
        # with a fallback, what reads the failed component's outputs goes on
        affected = [name] if fallback else downstream(name, edges)
        affected += self._chain_before(name, affected, edges, fallback)
        # (another lane's components take their inputs as they stand: the values stop)
        victims = [
            n for n in affected if n == name or (n in loaded and loaded[n].state == ACTIVE)
        ]
        taken = []
        for n in sorted(victims, key=order.index):  # (preceding controllers first)
            entry = loaded[n]
            entry.autostart = False
            if entry.state == ACTIVE:
                entry.state = INACTIVE
                taken.append(n)
        self._schedule.replan()
        for n in taken:  # as a deactivation (safe_stop runs, not stop)
            why = (
                f"on_error: deactivate, after {name!r} failed: {error}" if record
                else f"on_deadline: deactivate: {error}"
            )
            self._transitions.announce(
                n, TransitionOutcome(DEACTIVATE, ACTIVE, INACTIVE, SUCCESS, "", why)
            )
        self._run_safe_stops(sorted(victims, key=order.index, reverse=True))
        if fallback and not self._transitions.change(fallback, "activate").ok:
            fallback = ""
        if record:
            self._record(Fault(name, iteration, error, "deactivated", victims, fallback, cause))
        else:
            self._notices.log(LogLevel.WARNING, name, error)
        return fallback, taken

    def _chain_before(
        self, name: str, affected: list[str], edges: list[tuple[str, str]], fallback: str
    ) -> list[str]:
        """What goes out with ``affected`` because it is chained: the active controllers
        that command its reference interfaces (ros2_control's preceding controllers,
        transitively) and what reads their outputs, the other controllers they command
        included, so that none is left writing references nobody reads. Said in one line
        naming the chain."""
        hardware = self._transitions.hardware
        if hardware is None:  # no robot description: no chaining
            return []
        preceding: list[str] = []
        out = set(affected)
        queue = list(affected)
        while queue:
            for before in hardware.preceding(queue.pop(0)):
                if before in preceding:
                    continue
                preceding.append(before)
                for n in downstream(before, edges):
                    if n not in out and n != fallback:
                        out.add(n)
                        queue.append(n)
        if not preceding:
            return []
        order = self._topology.graph.order
        more = sorted(out - set(affected), key=order.index)
        chain = sorted([*preceding, name], key=order.index)
        self._notices.log(
            LogLevel.WARNING, name,
            f"chained: {' -> '.join(chain)}; taken out with it: {', '.join(more)} (no "
            "controller is left writing reference interfaces nobody reads); activate them "
            "again (switch_controller) once the fault is cleared")
        return more

    def _record(self, fault: Fault) -> None:
        self.faults.append(fault)
        self._notices.log(LogLevel.ERROR, fault.component, fault.describe())
        if self.on_fault is not None:
            self.on_fault(fault)

    def _run_safe_stops(self, names: Sequence[str]) -> list[SafeStopOutcome]:
        outcomes = []
        state = self._state
        running = state.running
        state.running = False  # a hook, not update: self.log.nonrt is fine
        try:
            for name in names:
                component = self._components.entries[name].component
                if not overrides(component, "safe_stop"):
                    continue
                try:
                    self._notices.observe(name, "safe_stop")
                    ok = component.safe_stop()
                    outcome = SafeStopOutcome(name, ok is not False, "returned False")
                except BaseException as exc:  # each runs on its own, whatever it raised
                    outcome = SafeStopOutcome(
                        name, False, f"raised {type(exc).__name__}: {exc}"
                    )
                if outcome.ok:
                    outcome.detail = ""
                outcomes.append(outcome)
                level = LogLevel.INFO if outcome.ok else LogLevel.ERROR
                self._notices.log(level, name, outcome.describe())
        finally:
            state.running = running
        self.safe_stops.extend(outcomes)
        self._notices.drain()
        return outcomes
