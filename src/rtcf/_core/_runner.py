"""The runner: holds components, wires them, and runs them in one loop.

Loading or unloading a component stops the loop, re-resolves the graph and, if the
mode allows, lets it start again, as the original rt_runner does. The compiled
schedule is a flat tuple of bound ``update`` methods whose ports already share
their slots; nothing is looked up by name while the loop runs.

:class:`Runner` is the face of the core that its callers use (the worker, the
command line, :mod:`rtcf.testing`, users): it builds its collaborators, which each
hold their own state, and passes each call to the one it concerns:

* :mod:`._components`: what is loaded, how it is constructed, described, tuned;
* :mod:`._transitions`: the components' lifecycle transitions, start and teardown;
* :mod:`._topology`: the data-flow graph over every lane's components, the lanes;
* :mod:`._schedule`: the plan of this runner's lane compiled into the Executor;
* :mod:`._loop`: the run, and whether the mode lets it start;
* :mod:`._containment`: what a failure's policy does, and the safe stops;
* :mod:`._notices`: the runner's own log records, and the hooks it tells of.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

from ._actions import ActionServer
from ._clock import Clock, MonotonicClock
from ._component import Component
from ._components import Components, ComponentSpec
from ._containment import Containment
from ._deadlines import DeadlineWatch
from ._errors import ComponentError, RtcfError
from ._executor import CONTROL, STOP, StopFlag
from ._faults import Fault, SafeStopOutcome
from ._graph import Graph, GraphNode
from ._hardware_loop import HardwareLoop
from ._lanes import Lane, Member, Step
from ._lifecycle import TransitionOutcome
from ._log import LogLevel, LogRecord, LogRing, PythonLoggingSink, RecordSink
from ._loop import Loop, RunResult
from ._loop_state import LoopState
from ._notices import Notices
from ._params import ParameterStore
from ._ports import InputPort, OutputPort, Slot
from ._rings import Ring
from ._schedule import BindHandover, Schedule
from ._settings import RunnerSettings
from ._switching import Switching
from ._topology import Topology
from ._transitions import Transitions
from ._tunables import LIFECYCLE, LOG_LEVEL, PARAMETER

# the runner's request and answer, importable from here as before
__all__ = ["ComponentSpec", "RunResult", "Runner"]


class Runner:
    """Loads components and runs them sequentially in one loop at ``settings.frequency``."""

    def __init__(
        self,
        settings: RunnerSettings | None = None,
        *,
        clock: Clock | None = None,
        parameters: ParameterStore | None = None,
        name: str = "rt_runner",
        log_sink: Callable[[LogRecord], None] | None = None,
        log_capacity: int = 4096,
        log_level: int | str = "info",
        timing_capacity: int = 1 << 12,
        log_ring: RecordSink | None = None,
        log_emit: Callable[[int, str, str, int, int], None] | None = None,
        stop_flag: StopFlag | None = None,
        offline: bool = False,
    ) -> None:
        """``offline``: the robot description's hardware is built to ``on_init`` only,
        never configured or activated (tools that inspect a launch file: no bus opened,
        no device touched)."""
        self.settings = settings or RunnerSettings()
        self.name = name
        self.clock: Clock = clock or MonotonicClock()
        self.parameters = parameters if parameters is not None else ParameterStore()
        self.state = LoopState(self.settings.frequency)
        # in a worker the records go to shared memory and the supervisor drains them
        self._notices = Notices(
            self.state,
            log_ring if log_ring is not None else LogRing(log_capacity),
            log_sink or PythonLoggingSink(),
            log_emit,
        )
        level = LogLevel[log_level.upper()] if isinstance(log_level, str) else log_level
        # the robot description's hardware, built here: in a worker, the loop's process
        self.hardware = HardwareLoop.from_settings(
            self.settings, self.state, self._notices.ring, name, offline=offline)
        # the collaborators, each given what it needs (none sees the runner itself)
        self._components = Components(
            self.settings, self.parameters, self.state, self._notices, level
        )
        self._topology = Topology(self._components, self.settings, name)
        self._schedule = Schedule(
            self._components, self._topology, self.settings, self.clock, self.state
        )
        self._transitions = Transitions(self._components, self.state, self._notices,
                                        self._schedule.replan, lambda: self._invalidate(CONTROL))
        self._containment = Containment(
            name,
            self._components,
            self._topology,
            self._schedule,
            self._transitions,
            self.state,
            self._notices,
        )
        self._switching = Switching(name, self._transitions, self.hardware, self._notices)
        # the totals of the hardware's command limits (a worker shares their cells)
        self.command_counters = self._schedule.commands
        # inputs with a deadline, watched at each iteration boundary (docs/runner.md)
        self.deadlines = DeadlineWatch(
            self.state, self._components, self._containment, self._notices
        )
        self._loop = Loop(
            name,
            self.settings,
            self.clock,
            self.state,
            self._notices,
            topology=self._topology,
            schedule=self._schedule,
            transitions=self._transitions,
            containment=self._containment,
            deadlines=self.deadlines,
            stop_flag=stop_flag,
            timing_capacity=timing_capacity,
        )
        if self.hardware is not None:
            self._components.hardware = self.hardware.keys
            self._schedule.hardware = self._transitions.hardware = self.hardware
            self.hardware.deactivate = lambda n: self._transitions.change(n, "deactivate")
            self._loop.hardware_feeder = self.hardware.feeder
            self.hardware.announce = self._transitions.announce
            self.hardware.components = lambda: self.components  # chained controllers
            self.hardware.chain_mode = self._transitions.set_chained

    # -- what is loaded, and how it is wired (Components) ---------------------------
    @property
    def components(self) -> dict[str, Component]:
        """The loaded components by full name, in load order."""
        return self._components.by_name()

    @property
    def log_level(self) -> int:
        """A component's log level when it is loaded, unless its spec gives one."""
        return self._components.log_level

    @log_level.setter
    def log_level(self, level: int) -> None:
        self._components.log_level = level

    def load(self, spec: ComponentSpec) -> Component:
        """Construct and configure a component (construct only: ``spec.unconfigured``);
        the loop re-resolves before it next runs."""
        component = self._components.load(spec, self.lane)
        self._invalidate()
        return component

    def unload(self, name: str) -> None:
        """Stop and clean up a component and take it out of the loop."""
        entry = self._components.remove(name)
        self._invalidate()
        errors = self._transitions.teardown([entry])
        if errors:
            raise errors[0]

    def describe_component(self, name: str) -> dict[str, Any]:
        """A loaded component as tools show it: type, ports, parameters, tunables."""
        return self._components.describe(name)

    def introspect(self) -> dict[str, Any]:
        """What the original's introspection scripts show: components with their ports,
        connections with their publishers and subscribers and whether they reach the
        middleware, and the execution order."""
        components = self._components
        connections = components.connections(self.settings.maps_to_ros)
        try:
            order, problem = list(self.graph.order), ""
        except RtcfError as exc:
            order, problem = [], str(exc)
        return {
            "runner": self.name,
            "frequency": self.settings.frequency,
            "mode": self.settings.mode,
            "components": [components.describe(n) for n in components.entries],
            "connections": connections,
            "actions": components.actions(self.settings.maps_to_ros),
            "order": order,
            "problem": problem,
        }

    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        """Validate and set a tunable parameter; returns the value as set.

        In this process it takes effect at once: call it between iterations (from
        ``on_iteration``) or between runs. A worker gets its changes through
        :func:`apply_update`, at the start of an iteration.
        """
        return self._components.set_parameter(component, name, value)

    def set_log_level(self, component: str, level: int | str) -> None:
        """Records below ``level`` are dropped where they are made (never queued)."""
        self._components.set_log_level(component, level)

    def apply_update(
        self, kind: int, component: str, name: str, value: Any
    ) -> TransitionOutcome | None:
        """Apply an update the supervisor validated (a worker, between two iterations).

        A lifecycle transition (``name`` the transition) returns its outcome.
        """
        if kind == LIFECYCLE:  # a component's, or a hardware's state
            return self._switching.change(component, name)
        # (applied here rather than by a call into Components: it runs in the loop)
        entry = self._components.entries.get(component)
        if entry is None:  # unloaded after the supervisor sent it: nothing to change
            return None
        if kind == PARAMETER:
            tunable = entry.component.params.declared.get(name)
            if tunable is not None:
                tunable._apply(value)
        elif kind == LOG_LEVEL:
            entry.component.log.level = int(value)
        return None

    def fallbacks(self) -> dict[str, str]:
        """Loaded fallback components and the component each stands in for (on_error)."""
        return self._components.fallbacks()

    def graph_nodes(self) -> list[GraphNode]:
        """A node per component; a fallback's inputs count as its primary's (it runs in
        the primary's place in the order, and writes the primary's outputs)."""
        return self._components.graph_nodes()

    def members(self) -> list[Member]:
        """What the other lanes must know of this runner's components (with
        :meth:`graph_nodes`): lane, rate, cost, whether the loop calls them."""
        return self._components.members()

    def mapped_ports(self) -> tuple[list[OutputPort[Any]], list[InputPort[Any]]]:
        """Outputs whose topic maps to the middleware, and mapped inputs nothing here feeds.

        An input whose topic a component inside the runner produces is never fed from
        the middleware: that would be a second, non-real-time writer.
        """
        self._schedule.compiled()  # the ports are connected
        return self._components.mapped_ports()

    def mapped_actions(self) -> list[ActionServer]:
        """Action servers whose action's name maps to the middleware."""
        return self._components.mapped_actions()

    # -- lifecycle transitions (Transitions) ----------------------------------------
    def lifecycle_state(self, name: str) -> str:
        """A loaded component's lifecycle state: ``active``, ``inactive``, ``unconfigured``
        or ``finalized`` (a ROS 2 managed node's labels)."""
        return self._transitions.state_of(name)

    def change_state(self, name: str, transition: int | str) -> TransitionOutcome:
        """Run one component's lifecycle transition; the others go on as they were.

        ``transition`` is a label (``configure``, ``cleanup``, ``activate``,
        ``deactivate``, ``shutdown``) or a lifecycle_msgs id. It never raises: the
        outcome says what happened (``ok``, ``end``, ``reason``), and the runner logs it
        under the component's name. While the loop runs, call it between iterations:
        from ``on_iteration``, or (a worker) as an update at the start of an iteration,
        where the new plan already applies to that iteration. Between runs it applies
        at once. The hooks it runs may use ``self.log.nonrt``.
        """
        return self._transitions.change(name, transition)

    def switch(self, transitions: Sequence[tuple[str, int | str]], strict: bool = False
               ) -> list[TransitionOutcome]:
        """Transitions together; ``strict``: all or none, now (:mod:`._switching`)."""
        return self._switching.switch(transitions, strict)

    @property
    def transition_listeners(self) -> list[Callable[[str, TransitionOutcome], None]]:
        """Told of every lifecycle change of a component: a transition, a fault's
        take-out."""
        return self._transitions.listeners

    @transition_listeners.setter
    def transition_listeners(
        self, listeners: list[Callable[[str, TransitionOutcome], None]]
    ) -> None:
        self._transitions.listeners = listeners

    def start_components(self) -> None:
        """Activate (``start``) the components loaded since the loop last started, in
        execution order; ``run`` does it first. One that a lifecycle transition left
        inactive stays so."""
        self._loop.start_components()

    # -- the graph over every lane (Topology) ---------------------------------------
    @property
    def graph(self) -> Graph:
        """The resolved data-flow graph (built on demand after loads and unloads): of
        every lane's components, this process's and the others'."""
        return self._topology.graph

    @property
    def order(self) -> list[str]:
        return list(self.graph.order)

    def lanes(self) -> dict[str, Lane]:
        """Every lane with its members in the data-flow order, main first."""
        return self._topology.lanes()

    def lane_plan(self) -> list[Step]:
        """The steps of this runner's lane (the main lane in a runner of every lane)."""
        return self._topology.lane_plan(self._schedule.lane)

    def set_foreign(
        self,
        nodes: Sequence[GraphNode],
        members: Sequence[Member],
        mirror: Iterable[str] = (),
    ) -> None:
        """The components loaded in the other lanes' processes (a worker, between
        runs): the order, the rates and the handovers are computed over all of them.
        ``mirror``: topics of other lanes the main lane receives after each iteration
        whoever reads them (to trace them)."""
        self._topology.set_foreign(nodes, members, mirror)
        self._invalidate()

    # -- the compiled plan (Schedule) -----------------------------------------------
    @property
    def lane(self) -> str | None:
        """The lane this runner runs (None: every lane, in this process)."""
        return self._schedule.lane

    @lane.setter
    def lane(self, lane: str | None) -> None:
        self._schedule.lane = lane

    @property
    def handovers(self) -> BindHandover | None:
        """What makes a handover step of a lane plan (the runtime's shared memory),
        bound to the port whose slot it fills or reads."""
        return self._schedule.handovers

    @handovers.setter
    def handovers(self, handovers: BindHandover | None) -> None:
        self._schedule.handovers = handovers

    @property
    def running_cell(self) -> Any:
        """The executor's running-component word (a worker passes a shared-memory one)."""
        return self._schedule.running_cell

    @running_cell.setter
    def running_cell(self, cell: Any) -> None:
        self._schedule.running_cell = cell

    def recompile(self) -> None:
        """Compile the plan again before the next run (new handovers were bound)."""
        self._invalidate()

    def _invalidate(self, reason: int = STOP) -> None:
        """What the plan is built from changed: resolve and compile again before the
        next use (a first configure's ports: the run ends with CONTROL, to run again)."""
        if self.state.running:
            # loading or unloading stops the loop: it must not call a stale schedule
            self._loop.stop_flag.set(reason)
        self._topology.invalidate()
        self._schedule.invalidate()

    @property
    def schedule(self) -> list[str]:
        """Components whose update the loop calls, in order (those that override it)."""
        self._schedule.compiled()
        return list(self._schedule.labels)

    def rate_plan(self) -> list[str] | None:
        """The multi-rate plan as a table (components x phases of the hyperperiod) with
        each phase's cost, or None when every component runs every iteration."""
        return self._schedule.rate_plan()

    def foreign_slots(self) -> dict[str, Slot]:
        """The slots that hold the values of other lanes' topics in this process."""
        return self._schedule.foreign_slots()

    def visible_slots(self) -> dict[str, Slot]:
        """The slots other lanes read a LET lane's outputs from (a trace samples these)."""
        return self._schedule.visible_slots()

    @property
    def missed_releases(self) -> int:
        """Releases a LET lane skipped after overrunning its window (counted)."""
        return self._schedule.missed_releases

    @property
    def time_grid(self) -> tuple[int | None, int | None]:
        """Where the next iteration is due and the grid's origin (None: not started)."""
        return self._schedule.time_grid

    def resume_at(self, iteration: int, deadline_ns: int, origin_ns: int) -> None:
        """Run ``iteration`` next, due at ``deadline_ns``, on a time grid that starts at
        ``origin_ns``: where every lane of a run starts together."""
        self._schedule.resume_at(iteration, deadline_ns, origin_ns)

    # -- the run (Loop) -------------------------------------------------------------
    def activate(self) -> None:
        """Allow the loop to run (mode ``wait_for_trigger``; the original's activate_rt_loop)."""
        self._loop.triggered = True

    def deactivate(self) -> None:
        self._loop.triggered = False

    @property
    def ready(self) -> bool:
        """Whether the mode lets the loop run now."""
        return self.not_ready_reason() is None

    def not_ready_reason(self) -> str | None:
        """Why the mode does not let the loop run now (None: it does)."""
        return self._loop.not_ready_reason()

    def hardware_problems(self) -> list[str]:
        """What activating the loaded controllers on the robot's hardware would refuse
        (an interface no hardware exports, one claimed twice): ``rtcf check``'s."""
        if self.hardware is None:
            return []
        entries = self._components.entries
        return self.hardware.preflight(
            (name, e.component, e.autostart) for name, e in entries.items())

    def run(
        self,
        iterations: int | None = None,
        *,
        on_iteration: Callable[[], object] | None = None,
        drain_logs_every_iteration: bool = True,
        timing_ring: Ring | None = None,
        feeders: Sequence[Callable[[], object]] = (),
        ros_offset_ns: int | None = None,
    ) -> RunResult:
        """Run the loop for ``iterations`` iterations, or until :meth:`request_stop`.

        Timing rows go to ``timing_ring`` when given (a worker's shared memory, which
        the supervisor aggregates); otherwise to a ring in this process, aggregated
        here. When an update raises, the component's failure policy applies
        (:mod:`rtcf._core._faults`): under ``stop`` (the default) every active
        component's ``safe_stop`` runs and ComponentError names the component and the
        iteration; ``deactivate`` and ``restart`` contain the failure and the loop goes
        on. A watchdog that fires, or a stop word set to ABORT (a signal), also runs
        the safe stops; the first raises LoopError. The components stay loaded (call
        :meth:`shutdown`).

        ``ros_offset_ns`` is what to add to the clock's time for the ROS stamps of the
        iterations (the default: the clock's own offset, read as the run starts); a
        supervisor that stamps the run's records itself passes its own, so the two
        agree to the nanosecond.
        """
        return self._loop.run(
            iterations,
            on_iteration,
            drain_logs_every_iteration,
            timing_ring,
            feeders,
            ros_offset_ns,
        )

    @property
    def stop_flag(self) -> StopFlag:
        """The word that stops the loop (a worker's is in shared memory; a worker swaps
        in its lane link's decision for the runs of a lane)."""
        return self._loop.stop_flag

    @stop_flag.setter
    def stop_flag(self, flag: StopFlag) -> None:
        self._loop.stop_flag = flag

    def request_stop(self) -> None:
        """End the loop after the current iteration (safe from a signal handler)."""
        self._loop.stop_flag.set()

    # -- faults and safe stops (Containment) ----------------------------------------
    def safe_stop(self, reason: str = "") -> list[SafeStopOutcome]:
        """Run every active component's ``safe_stop``, last in the order first.

        Each runs on its own: one that raises or returns False is reported and the
        others still run. The outcomes are returned, logged, and kept in
        :attr:`safe_stops` (and in the run's result).
        """
        return self._containment.safe_stop(reason)

    @property
    def faults(self) -> list[Fault]:
        """The failures a policy contained in this runner's life."""
        return self._containment.faults

    @property
    def safe_stops(self) -> list[SafeStopOutcome]:
        """The outcomes of the last safe stop."""
        return self._containment.safe_stops

    @property
    def on_fault(self) -> Callable[[Fault], None] | None:
        """Told of each contained failure (a worker counts them)."""
        return self._containment.on_fault

    @on_fault.setter
    def on_fault(self, on_fault: Callable[[Fault], None] | None) -> None:
        self._containment.on_fault = on_fault

    # -- logs and hooks told outside the loop (Notices) -----------------------------
    def drain_logs(self) -> int:
        return self._notices.drain()

    @property
    def log_ring(self) -> RecordSink:
        return self._notices.ring

    @property
    def log_sink(self) -> Callable[[LogRecord], None]:
        return self._notices.sink

    @property
    def hook_observer(self) -> Callable[[str, str], None] | None:
        """Told (component, hook) before a hook outside the loop runs: a worker passes it
        on, so that its supervisor can name a hook that hangs."""
        return self._notices.observer

    @hook_observer.setter
    def hook_observer(self, observer: Callable[[str, str], None] | None) -> None:
        self._notices.observer = observer

    # -- teardown -------------------------------------------------------------------
    def shutdown(self) -> list[ComponentError]:
        """Stop and clean up every component, last in the order first.

        Every hook runs even if another one fails; the failures are returned.
        """
        loaded = self._components.entries
        entries = [loaded[n] for n in reversed(self._topology.stopping_order()) if n in loaded]
        self._components.entries.clear()
        self._invalidate()
        errors = self._transitions.teardown(entries)
        if self.hardware is not None:
            self.hardware.shutdown()
        return errors
