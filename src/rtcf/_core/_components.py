"""The components a runner holds: how they are loaded, described, tuned and wired.

:class:`ComponentSpec` is a request to load one (what an rt_launcher sends to its
runner); :class:`Components` constructs and configures it, keeps it by full name in
load order with its lifecycle state (:class:`Loaded`), and says what the graph and
the other lanes must know of it (nodes, members, fallbacks). What the loop does with
them is the schedule's (:mod:`rtcf._core._schedule`); their lifecycle transitions
are :mod:`rtcf._core._transitions`'.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ._actions import ActionServer
from ._chaining import ChainableComponent, reference_ports, references_of
from ._claims import claimed_topics
from ._component import Component, _attach, overrides
from ._errors import ComponentError, ConfigurationError, Location, RtcfError
from ._faults import FailurePolicy
from ._graph import GraphNode, PortInfo
from ._interface_ports import HardwareKeys, required_interfaces
from ._lane_names import validate_lane_name
from ._lanes import Member, lane_of
from ._lifecycle import INACTIVE, STATE_LABELS, UNCONFIGURED
from ._loader import load_component_class
from ._loop_state import LoopState
from ._message_types import type_name
from ._names import Resolver, join, normalize_namespace, validate_name
from ._notices import Notices
from ._params import ParameterStore
from ._ports import InputPort, OutputPort
from ._rates import Rate
from ._settings import RunnerSettings


@dataclass
class ComponentSpec:
    """A request to load one component (what an rt_launcher sends to its runner).

    Give the class either directly (``cls``) or as ``module`` and ``class_name``.
    ``params`` are private parameters (``gain`` means ``~gain``), added to the
    runner's parameter tree on load. ``topics_ignore_for_graph`` is a full-match
    regex; matching incoming connections do not constrain the order. ``log_level``
    is the component's start level (before ``configure``); None: the runner's.
    ``policy`` says what the loop does when its ``update`` raises (``on_error``).
    ``unconfigured``: constructed only, as ros2_control's ``load_controller`` leaves a
    controller; its ``configure`` first runs at a lifecycle ``configure`` (docs/runner.md,
    "Loading unconfigured").
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
    log_level: int | None = None
    policy: FailurePolicy = field(default_factory=FailurePolicy)
    rate: Rate = field(default_factory=Rate)  # how often it runs (rate, every, phase)
    lane: str = ""  # the worker process (lane) it runs in; "" or "main": the runner's own
    # False: it stays inactive when the loop next starts, until a lifecycle transition
    autostart: bool = True
    # True: constructed only (its __init__ runs, its params are in the tree), left
    # unconfigured with no ports; its first lifecycle configure declares them and the
    # graph is resolved again (ros2_control's load_controller)
    unconfigured: bool = False

    @property
    def full_name(self) -> str:
        return join(normalize_namespace(self.namespace), self.name)

    @property
    def type_name(self) -> str:
        if self.cls is not None:
            return f"{self.cls.__module__}.{self.cls.__qualname__}"
        return f"{self.module}.{self.class_name}"


@dataclass
class Loaded:
    spec: ComponentSpec
    component: Component
    ignore: re.Pattern[str] | None
    state: int = INACTIVE  # lifecycle (_lifecycle): loaded means configured (unless
    # the spec asks for it unconfigured)
    autostart: bool = True  # activated when the loop next starts (until a transition)
    restarts: int = 0  # times on_error restart brought it back


class Components:
    """The components loaded in this process, by full name in load order (``entries``)."""

    def __init__(
        self,
        settings: RunnerSettings,
        parameters: ParameterStore,
        state: LoopState,
        notices: Notices,
        log_level: int,
    ) -> None:
        self.settings = settings
        self.parameters = parameters
        self.state = state
        self.notices = notices
        self.log_level = log_level  # a component's start level, unless its spec says
        self.entries: dict[str, Loaded] = {}
        self.hardware: HardwareKeys | None = None  # the run's hardware interfaces, if any

    def by_name(self) -> dict[str, Component]:
        return {n: entry.component for n, entry in self.entries.items()}

    # -- loading ------------------------------------------------------------
    def load(self, spec: ComponentSpec, lane: str | None) -> Component:
        """Construct and configure a component (``lane``: the lane this runner runs;
        None: every lane); construct only when ``spec.unconfigured``."""
        file = spec.location.file if spec.location else None
        line = spec.location.line if spec.location else None
        full = spec.full_name

        def fail(msg: str, cause: BaseException | None = None) -> ComponentError:
            return _failed(spec, msg, cause)

        problem = validate_name(spec.name, what="component name")
        if problem or "/" in spec.name:
            raise fail(problem or "a component name must not contain '/'; use the namespace")
        problem = validate_lane_name(spec.lane) if spec.lane else None
        if problem:
            raise fail(f"lane {problem}")
        if lane is not None and lane_of(spec.lane) != lane:
            raise fail(f"is for lane {lane_of(spec.lane)!r}, but this runs lane {lane!r}")
        if full in self.entries:
            raise fail("is already loaded; give each component a unique name")
        s = self.settings
        if s.mode == "wait_for_components" and len(self.entries) >= s.num_components_expected:
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
        try:  # a rate that does not divide the frequency: say so before configure runs
            every, _ = spec.rate.divider(self.settings.frequency, full)
        except ConfigurationError as exc:
            raise ComponentError(exc.message, component=full, file=file, line=line) from None
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
            ring=self.notices.ring,
            state=self.state,
            emit=self.notices.emit,
            every=every,
            hardware=self.hardware,
            lane=lane_of(spec.lane),
        )
        component.log.set_level(self.log_level if spec.log_level is None else spec.log_level)
        entry = Loaded(spec, component, ignore, autostart=spec.autostart)
        if spec.unconfigured:  # ros2_control's load: constructed, on_init, no configure
            try:
                component.__init__()  # type: ignore[misc]
            except Exception as exc:
                self.notices.drain()
                raise fail(f"__init__() raised {type(exc).__name__}: {exc}", exc) from exc
            entry.state, entry.autostart = UNCONFIGURED, False
        elif not self.configure_first(entry, construct=True):
            raise fail("configure() returned False")
        self.entries[full] = entry
        return component

    def configure_first(self, entry: Loaded, construct: bool = False) -> bool:
        """The component's first ``configure`` (``construct``: its ``__init__`` first): at
        its load, or at its first lifecycle configure when it was loaded unconfigured.
        False: it returned False; ComponentError: it raised, or its ports do not fit the
        launch file's deadlines. Either way what it declared is forgotten."""
        component, spec = entry.component, entry.spec
        try:
            if construct:
                component.__init__()  # type: ignore[misc]
            self.notices.observe(spec.full_name, "configure")
            ok = component.configure()
        except Exception as exc:
            forget_declarations(component)
            self.notices.drain()
            said = (f"configure() failed: {exc}" if isinstance(exc, RtcfError)
                    else f"configure() raised {type(exc).__name__}: {exc}")
            raise _failed(spec, said, exc) from exc
        self.notices.drain()
        if ok is False:
            forget_declarations(component)
            return False
        try:  # the launch file's deadline/NAME replaces the component's
            spec.policy.apply_deadlines(component._rtcf_inputs)
        except ConfigurationError as exc:
            forget_declarations(component)
            raise _failed(spec, exc.message) from None
        component._rtcf_configured = True
        component.params.sealed = True
        return True

    def entry(self, name: str) -> Loaded:
        full = normalize_namespace(name) if name.startswith("/") else join("/", name)
        entry = self.entries.get(full)
        if entry is None:
            known = ", ".join(self.entries) or "none"
            raise ComponentError(f"component {full!r} is not loaded (loaded: {known})")
        return entry

    def remove(self, name: str) -> Loaded:
        """Take a component out (its hooks are the lifecycle's to run)."""
        entry = self.entry(name)
        del self.entries[entry.spec.full_name]
        return entry

    # -- tuning ---------------------------------------------------------------
    def describe(self, name: str) -> dict[str, Any]:
        """A loaded component as tools show it: type, ports, parameters, tunables."""
        entry = self.entry(name)
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
            "every": comp.every,  # runs every this many iterations (rate, every)
            "lane": lane_of(entry.spec.lane),
            # what a ros2_control controller manager calls its type (rtcf_controllers')
            "ros2_control_type": str(getattr(type(comp), "ros2_control_type", "")),
            "lifecycle": STATE_LABELS[entry.state],
            # False: loaded unconfigured and never configured since (no ports yet)
            "configured": bool(comp._rtcf_configured),
            "claims": claimed_topics(comp),  # its claimed command topics
            # its ports of hardware interfaces: (command keys, state keys)
            "interfaces": required_interfaces(comp),
            # a chainable controller's reference interfaces, as list_controllers names them
            "chainable": isinstance(comp, ChainableComponent),
            "references": list(refs.keys) if (refs := references_of(comp)) else [],
        }

    def connections(self, maps: Callable[[str], bool]) -> list[dict[str, Any]]:
        """Per topic, its publishers and subscribers and whether it reaches the
        middleware (``maps``), sorted by topic."""
        connections: dict[str, dict[str, Any]] = {}
        action = self._action_ports()
        for full, entry in self.entries.items():
            comp = entry.component
            roles = ((comp._rtcf_outputs, "publishers"), (comp._rtcf_inputs, "subscribers"))
            for table, role in roles:
                for port in table.values():
                    c = connections.setdefault(port.topic, {
                        "topic": port.topic,
                        "type": type_name(port.type),
                        "publishers": [],
                        "subscribers": [],
                        "ros": maps(port.topic) and id(port) not in action,
                    })
                    c[role].append(full)
        return [connections[t] for t in sorted(connections)]

    def actions(self, maps: Callable[[str], bool]) -> list[dict[str, Any]]:
        """The actions served, by name: type, component, whether mapped (``maps``)."""
        return sorted(
            ({"name": a.name, "type": type_name(a.type), "component": full, "ros": maps(a.name)}
             for full, e in self.entries.items() for a in e.component._rtcf_actions.values()),
            key=lambda a: a["name"],
        )

    def _action_ports(self) -> set[int]:
        """The ids of the ports actions cross on (mapped as actions, not as topics)."""
        return {id(p) for e in self.entries.values() for a in e.component._rtcf_actions.values()
                for p in (a._requests, a._events)}

    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        """Validate and set a tunable parameter; returns the value as set."""
        entry = self.entry(component)
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
        self.entry(component).component.log.set_level(level)

    # -- wiring ---------------------------------------------------------------
    def fallbacks(self) -> dict[str, str]:
        """Loaded fallback components and the component each stands in for (on_error)."""
        return {
            e.spec.policy.fallback: name
            for name, e in self.entries.items()
            if e.spec.policy.fallback in self.entries and e.spec.policy.fallback != name
        }

    def graph_nodes(self) -> list[GraphNode]:
        """A node per component; a fallback's inputs count as its primary's (it runs in
        the primary's place in the order, and writes the primary's outputs)."""
        fallbacks = self.fallbacks()
        extra: dict[str, list[PortInfo]] = {}
        for fb, primary in fallbacks.items():
            comp = self.entries[fb].component
            extra[primary] = [_info(primary, p) for p in comp._rtcf_inputs.values()]
        # chained controllers: a reference key is an edge from its claimant to its owner
        refs_in, refs_out = reference_ports(
            {n: e.component for n, e in self.entries.items() if n not in fallbacks})
        nodes = []
        for full, entry in self.entries.items():
            if full in fallbacks:
                continue
            comp = entry.component
            nodes.append(
                GraphNode(
                    name=full,
                    inputs=[_info(full, p) for p in comp._rtcf_inputs.values()]
                    + extra.get(full, []) + refs_in.get(full, []),
                    outputs=[
                        _info(full, p, p.name in comp._rtcf_claims)
                        for p in comp._rtcf_outputs.values()
                    ] + refs_out.get(full, []),
                    is_first=entry.spec.is_first,
                    ignore_pattern=entry.ignore,
                    label=type(comp).__name__,
                    lane=lane_of(entry.spec.lane),
                )
            )
        return nodes

    def members(self) -> list[Member]:
        """What the other lanes must know of these components (with
        :meth:`graph_nodes`): lane, rate, cost, whether the loop calls them."""
        frequency = self.settings.frequency
        out = []
        for full, entry in self.entries.items():
            every, phase = entry.spec.rate.divider(frequency, full)
            out.append(
                Member(
                    full,
                    lane_of(entry.spec.lane),
                    every,
                    phase,
                    entry.spec.rate.cost,
                    overrides(entry.component, "update"),
                )
            )
        return out

    def mapped_ports(self) -> tuple[list[OutputPort[Any]], list[InputPort[Any]]]:
        """Outputs whose topic maps to the middleware, and mapped inputs nothing here
        feeds (once the ports are connected: after the schedule compiled)."""
        maps = self.settings.maps_to_ros
        comps = [e.component for e in self.entries.values()]
        action = self._action_ports()  # mapped as actions, by their name
        outputs = [p for c in comps for p in c._rtcf_outputs.values()
                   if maps(p.topic) and id(p) not in action]
        inputs = [
            p
            for c in comps
            for p in c._rtcf_inputs.values()
            if p.producer is None and maps(p.topic) and id(p) not in action
        ]
        return outputs, inputs

    def mapped_actions(self) -> list[ActionServer]:
        """The action servers whose action's name maps to the middleware."""
        maps = self.settings.maps_to_ros
        return [a for e in self.entries.values() for a in e.component._rtcf_actions.values()
                if maps(a.name)]


def _failed(spec: ComponentSpec, msg: str, cause: BaseException | None = None
            ) -> ComponentError:
    where = spec.location
    full = spec.full_name
    err = ComponentError(f"component {full!r}: {msg}", component=full,
                         file=where.file if where else None, line=where.line if where else None)
    err.__cause__ = cause
    return err


def forget_declarations(component: Component) -> None:
    """What a first ``configure`` that failed declared: gone, so that the next one is a
    first one again (it may declare other ports)."""
    for table in (component._rtcf_inputs, component._rtcf_outputs, component._rtcf_actions,
                  component._rtcf_guards, component._rtcf_interfaces, component._rtcf_bound):
        table.clear()
    component._rtcf_claims.clear()
    component.params.declared = {}


def _port_info(port: Any) -> dict[str, Any]:
    info = {"name": port.name, "topic": port.topic, "type": type_name(port.type)}
    if getattr(port, "deadline", None) is not None:  # an input's, seconds
        info["deadline"] = port.deadline
    return info


def _info(component: str, port: Any, claimed: bool = False) -> PortInfo:
    return PortInfo(component, port.name, port.topic, port.type, claimed)
