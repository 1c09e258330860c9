"""The schedule: the plan of this runner's lane compiled into the loop's Executor.

Compiling connects the ports (an input shares its producer's slot; another lane's
topic arrives in a stand-in output's slot), gives the LET lanes of this process
their private slots and the step that copies them, spreads the rates over the
phases, and lists the updates (and, in a lane's worker, the bound handovers) in
order: a flat plan, with nothing looked up by name while the loop runs. It is
compiled on demand after what it is built from changes, on the time grid of the
executor before it. Which of its components run is replanned between iterations
when one's lifecycle state changes (:meth:`Schedule.replan`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ._clock import Clock
from ._command_limits import CommandGuard, Counters, Guarded
from ._component import Component
from ._components import Components
from ._executor import Executor
from ._hardware_loop import READ_LABEL, WRITE_LABEL, HardwareLoop
from ._lanes import LET_OUT, SEND, UPDATE, Lane, LocalLet, Member, Step, lane_of, lanes_of
from ._lifecycle import ACTIVE
from ._loop_state import LoopState
from ._ports import OutputPort, Slot
from ._rates import plan_table, spread
from ._settings import RunnerSettings
from ._topology import Topology

# makes the step of a handover, bound to the port whose slot it fills or reads
BindHandover = Callable[[Step, OutputPort[Any]], Callable[[], object]]


class Schedule:
    """The compiled plan of this runner's lane, and what compiling it made."""

    def __init__(
        self,
        components: Components,
        topology: Topology,
        settings: RunnerSettings,
        clock: Clock,
        state: LoopState,
    ) -> None:
        self._components = components
        self._topology = topology
        self._settings = settings
        self._clock = clock
        self._state = state
        # the lane this runner runs (None: every lane, in this process), and what makes
        # a handover step of a lane plan (the runtime's shared memory), bound to the
        # port whose slot it fills or reads
        self.lane: str | None = None
        self.handovers: BindHandover | None = None
        # the executor's running-component word (a worker passes a shared-memory one)
        self.running_cell: Any = None
        self.executor: Executor | None = None  # None: compiled before the next use
        self._previous: Executor | None = None  # the last executor, for the time grid
        self.labels: list[str] = []  # timing columns: components, and lanes' handovers
        self.rates: list[tuple[int, int]] = []  # (every, phase) per scheduled component
        self._stubs: dict[str, OutputPort[Any]] = {}  # foreign producers' topics
        # the totals of the command inputs' guards (a worker shares them with its
        # supervisor)
        self.commands = Counters()
        # the robot description's hardware: read first, written last, bound to the
        # components' interface ports (rtcf._core._hardware_loop); None: none
        self.hardware: HardwareLoop | None = None
        self._let_slots: dict[tuple[str, str], Slot] = {}  # in-process LET (lane, topic)
        self._visible: dict[str, Slot] = {}  # LET outputs as the other lanes see them

    def compiled(self) -> Executor:
        """The executor of the current plan (compiled now if it is not)."""
        if self.executor is None:
            self.executor = self._compile()
        return self.executor

    def invalidate(self) -> None:
        """Compile again before the next use (keeping the time grid)."""
        if self.executor is not None:
            self._previous = self.executor
        self.executor = None

    def replan(self) -> None:
        """Swap in the plan of the active components (between iterations)."""
        executor = self.executor
        if executor is not None:
            executor.set_active(self._active_flags())

    # -- what compiling made ----------------------------------------------------------
    def foreign_slots(self) -> dict[str, Slot]:
        """The slots that hold the values of other lanes' topics in this process."""
        self.compiled()
        return {t: p._slot for t, p in self._stubs.items()}

    def visible_slots(self) -> dict[str, Slot]:
        """The slots other lanes read a LET lane's outputs from (a trace samples these)."""
        self.compiled()
        return dict(self._visible)

    @property
    def missed_releases(self) -> int:
        """Releases a LET lane skipped after overrunning its window (counted)."""
        executor = self.executor or self._previous
        return executor.missed if executor is not None else 0

    @property
    def time_grid(self) -> tuple[int | None, int | None]:
        """Where the next iteration is due and the grid's origin (None: not started)."""
        executor = self.compiled()
        return executor.next_deadline_ns, executor.origin_ns

    def resume_at(self, iteration: int, deadline_ns: int, origin_ns: int) -> None:
        """Run ``iteration`` next, due at ``deadline_ns``, on a time grid that starts at
        ``origin_ns``: where every lane of a run starts together."""
        executor = self.compiled()
        executor.next_deadline_ns = deadline_ns
        if executor.origin_ns is None:
            executor.origin_ns = origin_ns
        self._state.iteration = iteration - executor.stride

    def rate_plan(self) -> list[str] | None:
        """The multi-rate plan as a table (components x phases of the hyperperiod) with
        each phase's cost, or None when every component runs every iteration."""
        self.compiled()
        if all(every == 1 for every, _ in self.rates):
            return None
        loaded = self._components.entries
        costs = [loaded[n].spec.rate.cost if n in loaded else 0.0 for n in self.labels]
        lanes = [
            lane_of(loaded[n].spec.lane) if n in loaded else self._topology.foreign_lane(n)
            for n in self.labels
        ]
        return plan_table(self.labels, self.rates, costs, self._settings.frequency, lanes)

    # -- compiling --------------------------------------------------------------------
    def _compile(self) -> Executor:
        graph = self._topology.graph
        loaded = self._components.entries
        fallbacks = self._components.fallbacks()
        outputs: dict[str, OutputPort[Any]] = {}
        for n, e in loaded.items():
            if n in fallbacks:
                continue
            for p in e.component._rtcf_outputs.values():
                first = outputs.setdefault(p.topic, p)
                if first is not p and p.name in e.component._rtcf_claims:
                    p._slot = first._slot  # claimed commands (the graph let them): one slot
        # a topic produced in another lane's process: its value arrives by a handover
        # into a stand-in output's slot, which this lane's readers share
        for node in self._topology.foreign_nodes:
            for info in node.outputs:
                stub = self._stubs.get(info.topic)
                if stub is None or stub.type is not info.type:
                    stub = self._stubs[info.topic] = OutputPort(node.name, info.name, info.type)
                    stub.topic = info.topic
                outputs.setdefault(info.topic, stub)
        for entry in loaded.values():
            for port in entry.component._rtcf_inputs.values():
                port._connect(outputs.get(port.topic))
        for fb in fallbacks:  # a fallback writes its primary's outputs: the same slots
            for out in loaded[fb].component._rtcf_outputs.values():
                if out.topic in outputs:
                    out._slot = outputs[out.topic]._slot
        everyone = self._topology.members()
        lanes = lanes_of(everyone, graph.order)
        let = {name: lane for name, lane in lanes.items() if lane.let}
        members = {m.name: m for m in everyone}
        # the rates of the loop's lock-step components, spread over the phases as one
        # plan in every lane; a LET lane's are its lane's
        spread_names = [
            n for n in graph.order if members[n].scheduled and members[n].lane not in let
        ]
        spread_rates = dict(
            zip(
                spread_names,
                spread(
                    spread_names,
                    [(members[n].every, members[n].phase) for n in spread_names],
                    [members[n].cost for n in spread_names],
                ),
                strict=True,
            )
        )
        for lane in let.values():
            for n in lane.members:
                spread_rates[n] = (lane.every, lane.phase)
        updates: list[Callable[[], object]] = []
        labels: list[str] = []
        rates: list[tuple[int, int]] = []
        always: list[bool] = []
        stride = 1

        def add(label: str, update: Callable[[], object], rate: tuple[int, int], pin: bool) -> None:
            labels.append(label)
            updates.append(update)
            rates.append(rate)
            always.append(pin)

        self._visible = {}
        hardware = self.hardware
        if hardware is not None:  # ros2_control's order: read, the controllers, write
            hardware.sync_references()  # chained controllers' references, to bind to
            add(READ_LABEL, hardware.read, (1, 0), True)
        if self.lane is None:  # every lane here, one after the other: the reference
            local = self._local_let(let, members)
            if local is not None:
                add("@let", local, (1, 0), True)
            for lane in let.values():  # released first, on what the step above took
                for n in lane.members:
                    if members[n].scheduled:
                        add(n, self._step_of(loaded[n].component), spread_rates[n], False)
            for n in graph.order:
                if members[n].scheduled and members[n].lane not in let:
                    add(n, self._step_of(loaded[n].component), spread_rates[n], False)
        else:
            here = lanes[self.lane]
            if here.let:
                stride = here.every
            for step in self._topology.steps(self.lane, lanes, members):
                if step.kind == UPDATE:
                    n = step.name
                    add(n, self._step_of(loaded[n].component), spread_rates[n], False)
                elif self.handovers is not None:
                    sent = step.kind in (SEND, LET_OUT)
                    at = outputs[step.name] if sent else self._stubs[step.name]
                    add(step.label, self.handovers(step, at), (1, 0), True)
                else:  # compiled to name the columns; the runtime binds the handovers
                    add(step.label, _unbound(step), (1, 0), True)
        if hardware is not None:
            add(WRITE_LABEL, hardware.write, (1, 0), True)
        self.labels = labels
        executor = Executor(
            updates,
            self._clock,
            self._state,
            wait_policy=self._settings.wait_policy,
        )
        executor.stride = stride
        executor.skip_missed = stride > 1
        self.rates = rates
        executor.set_rates(rates, self._active_flags(), always)
        if self.running_cell is not None:
            executor.running = self.running_cell
        executor.max_consecutive_overruns = self._settings.max_consecutive_overruns
        executor.max_overruns_per_second = self._settings.max_overruns_per_second
        executor.max_let_overruns = self._settings.max_let_overruns
        previous = self.executor or self._previous
        if previous is not None:  # keep time on the same grid as the iterations before
            executor.origin_ns = previous.origin_ns
            executor.next_deadline_ns = previous.next_deadline_ns
        return executor

    def _step_of(self, component: Component) -> Callable[[], object]:
        """A component's step: its update, behind its command inputs' guards if it has
        any (rtcf._core._command_limits)."""
        guards = list(component._rtcf_guards.values())
        step: Callable[[], object] = component.update
        if guards:
            for guard in guards:
                guard.prepare(component.period, self.commands)
            step = Guarded(component.full_name, component.update, guards)
        if self.hardware is not None and component._rtcf_bound:
            step = self.hardware.bind(component, step, self.commands)
        return step

    def guards(self) -> list[CommandGuard]:
        """Every loaded component's command input guards, in load order."""
        own = [g for e in self._components.entries.values()
               for g in e.component._rtcf_guards.values()]
        return own + (list(self.hardware.guards.values()) if self.hardware else [])

    def _active_flags(self) -> list[bool]:
        loaded = self._components.entries
        return [n not in loaded or loaded[n].state == ACTIVE for n in self.labels]

    def _local_let(self, let: dict[str, Lane], members: dict[str, Member]) -> LocalLet | None:
        """LET in this process: private slots for the LET lanes' crossing inputs and
        outputs, and the step that copies them at releases and window ends."""
        if not let:
            return None
        lane_of_comp = {n: m.lane for n, m in members.items()}
        comps = {n: e.component for n, e in self._components.entries.items()}
        writers = {p.topic: p for c in comps.values() for p in c._rtcf_outputs.values()}
        slots = self._let_slots
        takes: dict[str, dict[str, Slot]] = {name: {} for name in let}  # topic -> source
        shows: dict[str, dict[str, Slot]] = {name: {} for name in let}  # topic -> public
        for n, comp in comps.items():
            reader = lane_of_comp.get(n, "")
            for port in comp._rtcf_inputs.values():
                producer = port.producer
                source = lane_of_comp.get(producer.component, "") if producer else reader
                if source == reader or (source not in let and reader not in let):
                    continue
                topic = port.topic
                src = producer._slot if producer is not None else port._slot
                if source in let:  # what the others see of a LET lane's output
                    src = slots.setdefault(("", topic), Slot())
                    shows[source][topic] = src
                if reader in let:  # a LET lane's input, taken at its release
                    takes[reader][topic] = src
                    src = slots.setdefault((reader, topic), Slot())
                port._slot = src
        plan = []
        for name, lane in let.items():
            self._visible.update(shows[name])
            plan.append(
                (
                    lane.every,
                    lane.phase,
                    [(src, slots[(name, t)]) for t, src in sorted(takes[name].items())],
                    [(writers[t]._slot, dst) for t, dst in sorted(shows[name].items())],
                )
            )
        return LocalLet(self._state, plan)


def _unbound(step: Step) -> Callable[[], object]:
    def unbound() -> None:
        raise RuntimeError(f"lane handover {step.label!r} is not bound to its shared memory")

    return unbound
