"""Component lifecycle transitions: the hooks outside the loop's updates, and who hears.

One component's transition (``configure``, ``cleanup``, ``activate``, ``deactivate``,
``shutdown``) runs its hooks on the state machine of :mod:`rtcf._core._lifecycle`,
while the others go on as they were; the schedule is replanned around it. Starting
the components a run begins with, and stopping and cleaning them up when they are
unloaded or shut down, are lifecycle changes too. Every change is logged under the
component's name and told to the listeners (a worker tells its supervisor).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

from ._actions import abort_open
from ._chaining import chain_links, chained_first
from ._claims import activation_conflict, start_conflict
from ._components import Components, Loaded
from ._errors import ComponentError, ConfigurationError
from ._hardware_loop import HardwareLoop
from ._lifecycle import (
    ACTIVATE,
    ACTIVE,
    CLEANUP,
    CONFIGURE,
    DEACTIVATE,
    ERROR,
    ERRORPROCESSING,
    FAILURE,
    FINALIZED,
    INACTIVE,
    REFUSED,
    REQUESTS,
    RESULTS,
    STATE_LABELS,
    SUCCESS,
    UNCONFIGURED,
    UNKNOWN,
    TransitionOutcome,
    available_transitions,
    refused,
    resolve_transition,
)
from ._log import LogLevel
from ._loop_state import LoopState
from ._names import join, normalize_namespace
from ._notices import Notices


class Transitions:
    """Runs the loaded components' lifecycle transitions and tells the listeners.

    ``replan`` swaps the plan of the active components into the loop (the
    schedule's): called when a component leaves or joins the active ones. ``rewire``
    resolves the graph again before the loop next runs (and ends a running loop, to
    run again on the new plan): called when a component loaded unconfigured has
    declared its ports in its first configure.
    """

    def __init__(
        self,
        components: Components,
        state: LoopState,
        notices: Notices,
        replan: Callable[[], None],
        rewire: Callable[[], None] | None = None,
    ) -> None:
        self._components = components
        self._state = state
        self._notices = notices
        self._replan = replan
        self._rewire = rewire or replan
        # told of every lifecycle change of a component: a transition, a fault's take-out
        self.listeners: list[Callable[[str, TransitionOutcome], None]] = []
        # the run's hardware: activation claims a component's command interfaces, every
        # way out of active releases them (rtcf._core._hardware_loop)
        self.hardware: HardwareLoop | None = None

    def state_of(self, name: str) -> str:
        """A loaded component's lifecycle state: ``active``, ``inactive``, ``unconfigured``
        or ``finalized`` (a ROS 2 managed node's labels)."""
        return STATE_LABELS[self._components.entry(name).state]

    def change(self, name: str, transition: int | str) -> TransitionOutcome:
        """Run one component's lifecycle transition (see :meth:`Runner.change_state`)."""
        loaded = self._components.entries
        full = normalize_namespace(name) if name.startswith("/") else join("/", name)
        entry = loaded.get(full)
        if entry is None:
            known = ", ".join(loaded) or "none"
            return refused(UNKNOWN, f"component {full!r} is not loaded (loaded: {known})")
        if isinstance(transition, str) and transition.isdigit():
            transition = int(transition)
        tid = resolve_transition(entry.state, transition)
        conflict = activation_conflict(loaded, full) if tid == ACTIVATE else ""
        if not conflict and tid == ACTIVATE and self.hardware is not None:
            conflict = self.hardware.claim(full, entry.component)  # its interfaces' keys
        if not conflict and tid is not None and entry.state == ACTIVE and self.hardware:
            conflict = self.hardware.deactivation_conflict(full)  # chained: preceded
        if conflict:  # its claimed command topic is another active component's
            outcome = refused(entry.state, conflict)
        elif tid is None:
            allowed = ", ".join(
                f"{d.label} [{d.transition}]" for d in available_transitions(entry.state)
            )
            outcome = refused(
                entry.state,
                f"component {full!r} is {STATE_LABELS[entry.state]}: no transition "
                f"{transition!r} from there (available: {allowed or 'none'})",
            )
        else:
            running = self._state.running
            self._state.running = False  # hooks, not update: self.log.nonrt is fine
            first = not entry.component._rtcf_configured  # loaded unconfigured
            try:
                outcome = self._transition(entry, tid)
            finally:
                self._state.running = running
            if first and entry.component._rtcf_configured:  # its ports are new: rewire
                self._rewire()
        level = LogLevel.INFO if outcome.ok else LogLevel.ERROR
        self._notices.log(level, full, "lifecycle: " + outcome.describe())
        if outcome.result != REFUSED:
            self.announce(full, outcome)
        return outcome

    def announce(self, name: str, outcome: TransitionOutcome) -> None:
        if self.hardware is not None and outcome.end != ACTIVE:
            self.hardware.release(name)
        for listener in self.listeners:
            listener(name, outcome)

    def start(self, order: Sequence[str]) -> None:
        """Activate (``start``) the components loaded since the loop last started, in
        ``order``. One that a lifecycle transition left inactive stays so."""
        loaded = self._components.entries
        started = False
        standing_by = self._components.fallbacks()  # a fallback starts when its primary fails
        starting = [
            name for name in order
            if name in loaded  # (not another lane's)
            and loaded[name].state == INACTIVE and loaded[name].autostart
            and name not in standing_by
        ]
        conflict, second = start_conflict(loaded, starting)
        if conflict:
            where = loaded[second].spec.location
            raise ConfigurationError(
                conflict, file=where.file if where else None, line=where.line if where else None
            )
        if self.hardware is not None:  # chained controllers first, in chained mode
            starting = chained_first(starting, {n: loaded[n].component for n in starting})
            for chained in {link[2] for link in chain_links(
                    {n: loaded[n].component for n in starting})}:
                self.set_chained(chained, True)
        for name in starting:
            entry = loaded[name]
            problem = self.hardware.claim(name, entry.component, False) if self.hardware else ""
            if problem:  # as a spawner's activation fails: it stays inactive, the rest run
                self._notices.log(LogLevel.ERROR, name, "lifecycle: activate refused: " + problem)
                continue
            try:
                self._notices.observe(name, "start")
                ok = entry.component.start()
            except Exception as exc:
                self._notices.drain()
                raise ComponentError(
                    f"component {name!r}: start() raised {type(exc).__name__}: {exc}",
                    component=name,
                ) from exc
            if ok is False:
                self._notices.drain()
                raise ComponentError(f"component {name!r}: start() returned False", component=name)
            entry.state = ACTIVE
            started = True
            self.announce(name, TransitionOutcome(ACTIVATE, INACTIVE, ACTIVE, SUCCESS))
        if self.hardware is not None:
            self.hardware.reconcile()  # (a preceding one refused: the chained one leaves)
        if started:
            self._replan()
        self._notices.drain()

    def set_chained(self, name: str, chained: bool) -> None:
        """A chainable controller into or out of chained mode; an active one is restarted
        (``stop``, the mode, ``start``) as ros2_control restarts it."""
        entry = self._components.entries.get(name)
        component: Any = entry.component if entry is not None else None
        if entry is None or component._rtcf_chained == chained:
            return
        active = entry.state == ACTIVE
        running, self._state.running = self._state.running, False  # hooks: nonrt is fine
        try:
            problems = [self._hook(entry, "stop")[1]] if active else []
            try:
                refused_ = component.on_set_chained_mode(chained) is False
            except Exception as exc:
                refused_, problems = True, [*problems, f"on_set_chained_mode raised {exc!r}"]
            if not refused_:
                component._rtcf_chained = chained
            if active:
                problems.append(self._hook(entry, "start")[1])
        finally:
            self._state.running = running
        said = "; ".join(p for p in problems if p)
        self._notices.log(
            LogLevel.ERROR if said or refused_ else LogLevel.INFO, name,
            f"chained mode {'on' if chained else 'off'}"
            f"{' refused' if refused_ else ''}{' (restarted)' if active else ''}"
            f"{': ' + said if said else ''}")

    def teardown(self, entries: Iterable[Loaded]) -> list[ComponentError]:
        """Stop and clean up components taken out (unloaded, or shut down), in the order
        given; every hook runs even if another one fails; the failures are returned."""
        errors: list[ComponentError] = []
        for entry in entries:
            name = entry.spec.full_name
            if self.hardware is not None:
                self.hardware.release(name)
            hooks = _TEARDOWN.get(entry.state, ())
            for hook in hooks:
                try:
                    self._notices.observe(name, hook)
                    _call(entry.component, hook)
                except Exception as exc:
                    err = ComponentError(
                        f"component {name!r}: {hook}() raised {type(exc).__name__}: {exc}",
                        component=name,
                    )
                    err.__cause__ = exc
                    errors.append(err)
            entry.state = FINALIZED
        self._notices.drain()
        return errors

    def _transition(self, entry: Loaded, tid: int) -> TransitionOutcome:
        _, start, via = REQUESTS[tid]
        entry.autostart = False  # from now on it stays where it was put
        entry.state = via
        if start == ACTIVE:
            self._replan()  # out of the schedule before its hooks run
        cleanup_tried = False
        if tid == CONFIGURE and not entry.component._rtcf_configured:
            result, reason = self._configure_first(entry)
        elif tid == CONFIGURE:
            result, reason = self._reconfigure(entry)
        elif tid == CLEANUP:
            result, reason = self._hook(entry, "cleanup")
            cleanup_tried = True
        elif tid == ACTIVATE:
            for guard in entry.component._rtcf_guards.values():
                guard.reset()  # no last command to change from: it may have moved since
            result, reason = self._hook(entry, "start")
        elif tid == DEACTIVATE:
            result, reason = self._hook(entry, "stop")
        else:  # shutdown: every hook the component needs, whatever one returned
            result, reason = SUCCESS, ""
            if start == ACTIVE:
                result, reason = self._hook(entry, "stop")
            if start != UNCONFIGURED and result != ERROR:
                cleaned, why = self._hook(entry, "cleanup")
                cleanup_tried = True
                if cleaned != SUCCESS:
                    result, reason = cleaned, "; ".join(r for r in (reason, why) if r)
        _, end = RESULTS[(via, result)]
        error_result = ""
        if end == ERRORPROCESSING:
            entry.state = ERRORPROCESSING
            if cleanup_tried:
                error_result = FAILURE
                reason += "; error processing: cleanup() failed already, so it is finalized"
            else:
                error_result, why = self._hook(entry, "cleanup")
                if why:
                    reason += "; error processing: " + why
            end = RESULTS[(ERRORPROCESSING, error_result)][1]
        entry.state = end
        if end == ACTIVE or start == ACTIVE:
            self._replan()
        return TransitionOutcome(tid, start, end, result, error_result, reason)

    def _hook(self, entry: Loaded, hook: str) -> tuple[str, str]:
        """Run a lifecycle hook: success, failure (returned False) or error (raised)."""
        try:
            self._notices.observe(entry.spec.full_name, hook)
            ok = _call(entry.component, hook)
        except Exception as exc:
            return ERROR, f"{hook}() raised {type(exc).__name__}: {exc}"
        if ok is False:
            return FAILURE, f"{hook}() returned False"
        return SUCCESS, ""

    def _configure_first(self, entry: Loaded) -> tuple[str, str]:
        """configure() the first time (a component loaded unconfigured): its ports and
        tunables are declared now, as at a load."""
        try:
            if self._components.configure_first(entry):
                return SUCCESS, ""
        except ComponentError as exc:
            return ERROR, exc.message
        return FAILURE, "configure() returned False"

    def _reconfigure(self, entry: Loaded) -> tuple[str, str]:
        """configure() again: it must declare the ports and tunables of the first time."""
        comp = entry.component
        params = comp.params
        first = params.declared
        comp._rtcf_redeclared = set()
        comp._rtcf_configured = False
        params.previous, params.declared, params.sealed = first, {}, False
        try:
            result, reason = self._hook(entry, "configure")
            if result == SUCCESS:
                ports = set(comp._rtcf_inputs) | set(comp._rtcf_outputs) | set(comp._rtcf_bound)
                missing = [f"port {n!r}" for n in sorted(ports - comp._rtcf_redeclared)]
                missing += [
                    f"tunable parameter {n!r}" for n in sorted(set(first) - set(params.declared))
                ]
                if missing:
                    result, reason = ERROR, (
                        f"configure() did not declare {', '.join(missing)} again; configured "
                        "again, a component must declare the same ports and tunable parameters"
                    )
        finally:
            comp._rtcf_redeclared = None
            comp._rtcf_configured = True
            params.previous, params.declared, params.sealed = None, first, True
        return result, reason


def _call(component: object, hook: str) -> object:
    """Run one hook; after ``stop`` (the component runs no more) its open goals end."""
    try:
        return getattr(component, hook)()
    finally:
        if hook == "stop":
            abort_open(component)


# what unloading or shutting down runs, by lifecycle state (a transition state: a hook
# of it failed and error processing is under way; nothing more runs then)
_TEARDOWN = {ACTIVE: ("stop", "cleanup"), INACTIVE: ("cleanup",)}
