"""The runner: holds components, wires them, and runs them in one loop.

Loading or unloading a component stops the loop, re-resolves the graph and, if the
mode allows, lets it start again, as the original rt_runner does. The compiled
schedule is a flat tuple of bound ``update`` methods whose ports already share
their slots; nothing is looked up by name while the loop runs.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ._channels import Ring
from ._clock import Clock, MonotonicClock
from ._codec import type_name
from ._component import Component, _attach, overrides
from ._errors import ComponentError, ConfigurationError, RtcfError
from ._executor import Executor, StopFlag, UpdateFailure
from ._graph import Graph, GraphNode, PortInfo, build_graph
from ._launch_description import Location
from ._loader import load_component_class
from ._log import LogLevel, LogRecord, LogRing, PythonLoggingSink, RecordSink
from ._loop_state import LoopState
from ._names import Resolver, join, normalize_namespace, validate_name
from ._params import ParameterStore
from ._ports import InputPort, OutputPort
from ._settings import RunnerSettings
from ._timing import TimingAggregate, TimingSummary, TimingWriter, local_ring
from ._tunables import LOG_LEVEL, PARAMETER


@dataclass
class ComponentSpec:
    """A request to load one component (what an rt_launcher sends to its runner).

    Give the class either directly (``cls``) or as ``module`` and ``class_name``.
    ``params`` are private parameters (``gain`` means ``~gain``), added to the
    runner's parameter tree on load. ``topics_ignore_for_graph`` is a full-match
    regex; matching incoming connections do not constrain the order.
    """

    name: str
    cls: type[Component] | None = None
    module: str = ""
    class_name: str = ""
    namespace: str = "/"
    remaps: list[tuple[str, str]] | Mapping[str, str] = field(default_factory=list)
    params: Mapping[str, Any] = field(default_factory=dict)
    is_first: bool = False
    topics_ignore_for_graph: str = ""
    location: Location | None = None

    @property
    def full_name(self) -> str:
        return join(normalize_namespace(self.namespace), self.name)

    @property
    def type_name(self) -> str:
        if self.cls is not None:
            return f"{self.cls.__module__}.{self.cls.__qualname__}"
        return f"{self.module}.{self.class_name}"


@dataclass
class _Loaded:
    spec: ComponentSpec
    component: Component
    ignore: re.Pattern[str] | None
    started: bool = False


@dataclass
class RunResult:
    """What one call of :meth:`Runner.run` did."""

    iterations: int
    stopped_by: str  # "count", "stop" or "error"
    timing: TimingSummary
    order: list[str]
    log_records_dropped: int
    simulated: bool
    # filled in by a supervisor: what the worker applied, and the full histograms
    realtime: dict[str, Any] | None = None
    aggregate: TimingAggregate | None = None


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
    ) -> None:
        self.settings = settings or RunnerSettings()
        self.name = name
        self.clock: Clock = clock or MonotonicClock()
        self.parameters = parameters if parameters is not None else ParameterStore()
        self.state = LoopState(self.settings.frequency)
        # in a worker the records go to shared memory and the supervisor drains them
        self.log_ring: RecordSink = log_ring if log_ring is not None else LogRing(log_capacity)
        self.log_sink = log_sink or PythonLoggingSink()
        self._log_emit = log_emit or self._emit_now
        # a worker's flag is a shared-memory word the supervisor sets and clears
        self._owns_stop_flag = stop_flag is None
        self.stop_flag = stop_flag if stop_flag is not None else StopFlag()
        self.log_level = LogLevel[log_level.upper()] if isinstance(log_level, str) else log_level
        self._timing_capacity = timing_capacity
        self._loaded: dict[str, _Loaded] = {}
        self._triggered = False
        self._graph: Graph | None = None
        self._executor: Executor | None = None
        self._previous: Executor | None = None  # the last executor, for the time grid
        self._schedule: list[str] = []

    # -- loading ------------------------------------------------------------
    @property
    def components(self) -> dict[str, Component]:
        return {n: entry.component for n, entry in self._loaded.items()}

    def load(self, spec: ComponentSpec) -> Component:
        """Construct and configure a component; the loop re-resolves before it next runs."""
        file = spec.location.file if spec.location else None
        line = spec.location.line if spec.location else None
        full = spec.full_name

        def fail(msg: str, cause: BaseException | None = None) -> ComponentError:
            err = ComponentError(f"component {full!r}: {msg}", component=full, file=file, line=line)
            err.__cause__ = cause
            return err

        problem = validate_name(spec.name, what="component name")
        if problem or "/" in spec.name:
            raise fail(problem or "a component name must not contain '/'; use the namespace")
        if full in self._loaded:
            raise fail("is already loaded; give each component a unique name")
        s = self.settings
        if s.mode == "wait_for_components" and len(self._loaded) >= s.num_components_expected:
            raise fail(
                f"is one more than the {s.num_components_expected} components this runner "
                "expects (num_components_expected); raise that number or load fewer"
            )
        try:
            ignore = (
                re.compile(spec.topics_ignore_for_graph) if spec.topics_ignore_for_graph else None
            )
        except re.error as exc:
            raise fail(
                f"topics_ignore_for_graph {spec.topics_ignore_for_graph!r} is not a valid "
                f"regular expression: {exc}"
            ) from None
        cls = spec.cls
        if cls is None:
            try:
                cls = load_component_class(spec.module, spec.class_name, component=full)
            except ComponentError as exc:
                raise ComponentError(
                    exc.message, component=full, file=file, line=line
                ) from exc.__cause__
        namespace = normalize_namespace(spec.namespace)
        resolver = Resolver(namespace, spec.name, spec.remaps)
        for key, value in spec.params.items():
            self.parameters.set(resolver.private(key), value)

        component = cls.__new__(cls)
        _attach(
            component,
            name=spec.name,
            namespace=namespace,
            resolver=resolver,
            store=self.parameters,
            ring=self.log_ring,
            state=self.state,
            emit=self._log_emit,
        )
        component.log.set_level(self.log_level)
        try:
            component.__init__()  # type: ignore[misc]
            ok = component.configure()
        except RtcfError as exc:
            self.drain_logs()
            raise fail(f"configure() failed: {exc}", exc) from exc
        except Exception as exc:
            self.drain_logs()
            raise fail(f"configure() raised {type(exc).__name__}: {exc}", exc) from exc
        self.drain_logs()
        if ok is False:
            raise fail("configure() returned False")
        component._rtcf_configured = True
        component.params.sealed = True
        self._loaded[full] = _Loaded(spec, component, ignore)
        self._invalidate()
        return component

    def _entry(self, name: str) -> _Loaded:
        full = normalize_namespace(name) if name.startswith("/") else join("/", name)
        entry = self._loaded.get(full)
        if entry is None:
            known = ", ".join(self._loaded) or "none"
            raise ComponentError(f"component {full!r} is not loaded (loaded: {known})")
        return entry

    def unload(self, name: str) -> None:
        """Stop and clean up a component and take it out of the loop."""
        entry = self._entry(name)
        full = entry.spec.full_name
        del self._loaded[full]
        self._invalidate()
        errors = self._teardown([entry])
        if errors:
            raise errors[0]

    # -- tuning ---------------------------------------------------------------
    def describe_component(self, name: str) -> dict[str, Any]:
        """A loaded component as tools show it: type, ports, parameters, tunables."""
        entry = self._entry(name)
        comp = entry.component
        full = entry.spec.full_name
        private = self.parameters.get(comp._rtcf_resolver.private(), {})
        return {
            "name": full,
            "type": entry.spec.type_name,
            "launcher": "",
            "inputs": [_port_info(p) for p in comp._rtcf_inputs.values()],
            "outputs": [_port_info(p) for p in comp._rtcf_outputs.values()],
            "parameters": private if isinstance(private, dict) else {},
            "tunables": [
                {**t.spec.to_dict(), "value": t.value} for t in comp.params.declared.values()
            ],
            "log_level": comp.log.level,
        }

    def introspect(self) -> dict[str, Any]:
        """What the original's introspection scripts show: components with their ports,
        connections with their publishers and subscribers and whether they reach the
        middleware, and the execution order."""
        maps = self.settings.maps_to_ros
        connections: dict[str, dict[str, Any]] = {}
        for full, entry in self._loaded.items():
            comp = entry.component
            roles = ((comp._rtcf_outputs, "publishers"), (comp._rtcf_inputs, "subscribers"))
            for table, role in roles:
                for port in table.values():
                    c = connections.setdefault(port.topic, {
                        "topic": port.topic,
                        "type": type_name(port.type),
                        "publishers": [],
                        "subscribers": [],
                        "ros": maps(port.topic),
                    })
                    c[role].append(full)
        try:
            order, problem = list(self.graph.order), ""
        except RtcfError as exc:
            order, problem = [], str(exc)
        return {
            "runner": self.name,
            "frequency": self.settings.frequency,
            "mode": self.settings.mode,
            "components": [self.describe_component(n) for n in self._loaded],
            "connections": [connections[t] for t in sorted(connections)],
            "order": order,
            "problem": problem,
        }

    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        """Validate and set a tunable parameter; returns the value as set.

        In this process it takes effect at once: call it between iterations (from
        ``on_iteration``) or between runs. A worker gets its changes through
        :func:`apply_update`, at the start of an iteration.
        """
        entry = self._entry(component)
        tunable = entry.component.params.declared.get(name)
        if tunable is None:
            known = ", ".join(entry.component.params.declared) or "none"
            raise ConfigurationError(
                f"component {entry.spec.full_name!r} has no tunable parameter {name!r} "
                f"(it declares: {known})"
            )
        value = tunable.spec.validate(value)
        tunable._apply(value)
        return value

    def set_log_level(self, component: str, level: int | str) -> None:
        """Records below ``level`` are dropped where they are made (never queued)."""
        self._entry(component).component.log.set_level(level)

    def apply_update(self, kind: int, component: str, name: str, value: Any) -> None:
        """Apply an update the supervisor validated (a worker, between two iterations)."""
        entry = self._loaded.get(component)
        if entry is None:  # unloaded after the supervisor sent it: nothing to change
            return
        if kind == PARAMETER:
            tunable = entry.component.params.declared.get(name)
            if tunable is not None:
                tunable._apply(value)
        elif kind == LOG_LEVEL:
            entry.component.log.level = int(value)

    def activate(self) -> None:
        """Allow the loop to run (mode ``wait_for_trigger``; the original's activate_rt_loop)."""
        self._triggered = True

    def deactivate(self) -> None:
        self._triggered = False

    @property
    def ready(self) -> bool:
        """Whether the mode lets the loop run now."""
        return self.not_ready_reason() is None

    def not_ready_reason(self) -> str | None:
        s, n = self.settings, len(self._loaded)
        if n == 0:
            return "no component is loaded"
        if s.mode == "wait_for_components" and n < s.num_components_expected:
            return (
                f"mode wait_for_components: {n} of the {s.num_components_expected} expected "
                "components are loaded (num_components_expected)"
            )
        if s.mode == "wait_for_trigger" and not self._triggered:
            return "mode wait_for_trigger: the loop has not been activated"
        return None

    # -- resolving ------------------------------------------------------------
    def _invalidate(self) -> None:
        if self.state.running:
            # loading or unloading stops the loop: it must not call a stale schedule
            self.stop_flag.set()
        self._graph = None
        if self._executor is not None:
            self._previous = self._executor
        self._executor = None

    def graph_nodes(self) -> list[GraphNode]:
        nodes = []
        for full, entry in self._loaded.items():
            comp = entry.component
            nodes.append(
                GraphNode(
                    name=full,
                    inputs=[_info(full, p) for p in comp._rtcf_inputs.values()],
                    outputs=[_info(full, p) for p in comp._rtcf_outputs.values()],
                    is_first=entry.spec.is_first,
                    ignore_pattern=entry.ignore,
                    label=type(comp).__name__,
                )
            )
        return nodes

    @property
    def graph(self) -> Graph:
        """The resolved data-flow graph (built on demand after loads and unloads)."""
        if self._graph is None:
            self._graph = build_graph(self.graph_nodes())
        return self._graph

    @property
    def order(self) -> list[str]:
        return list(self.graph.order)

    def _compile(self) -> Executor:
        graph = self.graph
        outputs = {
            p.topic: p for e in self._loaded.values() for p in e.component._rtcf_outputs.values()
        }
        for entry in self._loaded.values():
            for port in entry.component._rtcf_inputs.values():
                port._connect(outputs.get(port.topic))
        # components whose update is not overridden cost nothing in the loop
        scheduled = [n for n in graph.order if overrides(self._loaded[n].component, "update")]
        self._schedule = scheduled
        executor = Executor(
            [self._loaded[n].component.update for n in scheduled],
            self.clock,
            self.state,
            wait_policy=self.settings.wait_policy,
        )
        previous = self._executor or self._previous
        if previous is not None:  # keep time on the same grid as the iterations before
            executor.origin_ns = previous.origin_ns
            executor.next_deadline_ns = previous.next_deadline_ns
        return executor

    def _start_components(self) -> None:
        for name in self.graph.order:
            entry = self._loaded[name]
            if entry.started:
                continue
            try:
                ok = entry.component.start()
            except Exception as exc:
                self.drain_logs()
                raise ComponentError(
                    f"component {name!r}: start() raised {type(exc).__name__}: {exc}",
                    component=name,
                ) from exc
            if ok is False:
                self.drain_logs()
                raise ComponentError(f"component {name!r}: start() returned False", component=name)
            entry.started = True
        self.drain_logs()

    # -- running ------------------------------------------------------------
    def run(
        self,
        iterations: int | None = None,
        *,
        on_iteration: Callable[[], object] | None = None,
        drain_logs_every_iteration: bool = True,
        timing_ring: Ring | None = None,
        feeders: Sequence[Callable[[], object]] = (),
    ) -> RunResult:
        """Run the loop for ``iterations`` iterations, or until :meth:`request_stop`.

        Timing rows go to ``timing_ring`` when given (a worker's shared memory, which
        the supervisor aggregates); otherwise to a ring in this process, aggregated
        here. Raises ComponentError naming the component and iteration when an
        update raises; the components stay loaded (call :meth:`shutdown`).
        """
        reason = self.not_ready_reason()
        if reason is not None:
            raise ConfigurationError(f"runner {self.name!r} cannot run: {reason}")
        if self._executor is None:
            self._executor = self._compile()
        executor = self._executor
        self._start_components()
        aggregate = None
        if timing_ring is None:
            timing_ring = local_ring(len(self._schedule), self._timing_capacity)
            aggregate = TimingAggregate()
        writer = TimingWriter(self._schedule, timing_ring)
        executor.timing = writer
        executor.feeders = tuple(feeders)
        executor.idle = self._idle_hook(
            on_iteration, drain_logs_every_iteration, aggregate, timing_ring
        )
        if self._owns_stop_flag:
            self.stop_flag.clear()
        try:
            ran = executor.run(iterations, self.stop_flag)
        except UpdateFailure as failure:
            self.drain_logs()
            name = self._schedule[failure.index]
            exc = failure.error
            raise ComponentError(
                f"component {name!r}: update() raised {type(exc).__name__}: {exc} "
                f"at iteration {failure.iteration} (t={failure.time_ns * 1e-9:.6f} s); "
                "the loop was stopped",
                component=name,
            ) from exc
        finally:
            executor.idle = None
            executor.timing = None
            executor.feeders = ()
            writer.release()
        self.drain_logs()
        stopped_by = "count" if iterations is not None and ran >= iterations else "stop"
        if aggregate is not None:
            aggregate.finish(timing_ring, self._schedule)
            timing = aggregate.summary(writer.count, writer.overruns)
        else:
            timing = TimingSummary(iterations=writer.count, samples=0, overruns=writer.overruns)
        return RunResult(
            iterations=ran,
            stopped_by=stopped_by,
            timing=timing,
            order=list(self.graph.order),
            log_records_dropped=self.log_ring.dropped,
            simulated=bool(getattr(self.clock, "simulated", False)),
        )

    def _idle_hook(
        self,
        on_iteration: Callable[[], object] | None,
        drain: bool,
        aggregate: TimingAggregate | None,
        timing_ring: Ring,
    ) -> Callable[[], object] | None:
        ring = self.log_ring if isinstance(self.log_ring, LogRing) else None
        sink = self.log_sink
        names = self._schedule
        half = timing_ring.capacity // 2
        if not drain and aggregate is None:
            return on_iteration

        def idle() -> None:
            if drain and ring is not None and len(ring):
                ring.drain(sink, 64)
            if aggregate is not None and len(timing_ring) >= half:
                aggregate.consume(timing_ring, names)
            if on_iteration is not None:
                on_iteration()

        return idle

    def request_stop(self) -> None:
        """End the loop after the current iteration (safe from a signal handler)."""
        self.stop_flag.set()

    def mapped_ports(self) -> tuple[list[OutputPort[Any]], list[InputPort[Any]]]:
        """Outputs whose topic maps to the middleware, and mapped inputs nothing here feeds.

        An input whose topic a component inside the runner produces is never fed from
        the middleware: that would be a second, non-real-time writer.
        """
        if self._executor is None:
            self._executor = self._compile()
        maps = self.settings.maps_to_ros
        comps = [e.component for e in self._loaded.values()]
        outputs = [p for c in comps for p in c._rtcf_outputs.values() if maps(p.topic)]
        inputs = [
            p
            for c in comps
            for p in c._rtcf_inputs.values()
            if p.producer is None and maps(p.topic)
        ]
        return outputs, inputs

    @property
    def schedule(self) -> list[str]:
        """Components whose update the loop calls, in order (those that override it)."""
        if self._executor is None:
            self._executor = self._compile()
        return list(self._schedule)

    def drain_logs(self) -> int:
        ring = self.log_ring
        return ring.drain(self.log_sink) if isinstance(ring, LogRing) else 0

    def _emit_now(self, level: int, logger: str, text: str, iteration: int, time_ns: int) -> None:
        """Non-real-time logging in this process: after what the ring holds, in order."""
        self.drain_logs()
        self.log_sink(LogRecord(level, logger, text, iteration, time_ns))

    def shutdown(self) -> list[ComponentError]:
        """Stop and clean up every component, last in the order first.

        Every hook runs even if another one fails; the failures are returned.
        """
        try:
            order = self.graph.order
        except RtcfError:
            order = list(self._loaded)
        entries = [self._loaded[n] for n in reversed(order) if n in self._loaded]
        self._loaded.clear()
        self._invalidate()
        return self._teardown(entries)

    def _teardown(self, entries: Iterable[_Loaded]) -> list[ComponentError]:
        errors: list[ComponentError] = []
        for entry in entries:
            name = entry.spec.full_name
            hooks = ("stop", "cleanup") if entry.started else ("cleanup",)
            for hook in hooks:
                try:
                    getattr(entry.component, hook)()
                except Exception as exc:
                    err = ComponentError(
                        f"component {name!r}: {hook}() raised {type(exc).__name__}: {exc}",
                        component=name,
                    )
                    err.__cause__ = exc
                    errors.append(err)
            entry.started = False
        self.drain_logs()
        return errors


def _port_info(port: Any) -> dict[str, Any]:
    return {"name": port.name, "topic": port.topic, "type": type_name(port.type)}


def _info(component: str, port: Any) -> PortInfo:
    return PortInfo(component, port.name, port.topic, port.type)
