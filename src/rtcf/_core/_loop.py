"""The run: the schedule's executor driven for a number of iterations, or until stopped.

Before a run the mode must let the loop start (``wait_for_components``,
``wait_for_trigger``) and the components loaded since the last run are started.
While it runs, what happens between iterations (the log drained, the timing
aggregated, ``on_iteration``) is one idle step the executor calls; a failure the
executor raises is contained (:mod:`rtcf._core._containment`) and the run goes on
where the policy lets it. What it did comes back as a :class:`RunResult`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from ._clock import Clock
from ._containment import Containment
from ._deadlines import DeadlineEvent, DeadlineWatch
from ._errors import ConfigurationError, LoopError
from ._executor import ABORT, StopFlag, UpdateFailure
from ._faults import Fault, SafeStopOutcome, WatchdogTripped
from ._lane_names import MAIN_LANE
from ._log import LogRing
from ._loop_state import LoopState
from ._notices import Notices
from ._rings import Ring
from ._schedule import Schedule
from ._settings import RunnerSettings
from ._timing import TimingAggregate, TimingSummary, TimingWriter, local_ring
from ._topology import Topology
from ._transitions import Transitions


@dataclass
class RunResult:
    """What one call of :meth:`Runner.run` did."""

    iterations: int
    stopped_by: str  # "count", "stop" or "abort" (a signal: safe_stop hooks ran)
    timing: TimingSummary
    order: list[str]
    log_records_dropped: int
    simulated: bool
    realtime: dict[str, Any] | None = None  # what a worker applied (by a supervisor)
    # the full histograms (a supervisor's, or the runner's own local ring's)
    aggregate: TimingAggregate | None = None
    faults: list[Fault] = field(default_factory=list)  # failures contained by a policy
    safe_stops: list[SafeStopOutcome] = field(default_factory=list)
    # lanes in worker processes of their own: per lane other than main, what it did
    # (iterations, overruns, timing, handovers late or lost, LET overruns)
    lanes: dict[str, dict[str, Any]] = field(default_factory=dict)
    # inputs mapped to the middleware (by a supervisor): per topic, the messages that
    # arrived, those the loop read, and those a newer one replaced before it read them
    inputs: dict[str, dict[str, int]] = field(default_factory=dict)
    # inputs with a deadline: per input (component.name), how many times it passed it
    # and for how long in all (this runner's life); and each time, in this run
    deadlines: dict[str, dict[str, Any]] = field(default_factory=dict)
    deadline_events: list[DeadlineEvent] = field(default_factory=list)
    # hardware's command inputs (component.name): what their limits clamped, per
    # joint, and refused (this runner's life; rtcf._core._command_limits)
    command_limits: dict[str, dict[str, Any]] = field(default_factory=dict)


class Loop:
    """Runs a runner's loop: whether it may start, its runs, and the word that stops it."""

    def __init__(
        self,
        name: str,
        settings: RunnerSettings,
        clock: Clock,
        state: LoopState,
        notices: Notices,
        *,
        topology: Topology,
        schedule: Schedule,
        transitions: Transitions,
        containment: Containment,
        deadlines: DeadlineWatch,
        stop_flag: StopFlag | None,
        timing_capacity: int,
    ) -> None:
        self._name = name  # the runner's, for its messages
        self._settings = settings
        self._clock = clock
        self._state = state
        self._notices = notices
        self._topology = topology
        self._schedule = schedule
        self._transitions = transitions
        self._containment = containment
        self._deadlines = deadlines
        # a worker's flag is a shared-memory word the supervisor sets and clears
        self._owns_stop_flag = stop_flag is None
        self.stop_flag = stop_flag if stop_flag is not None else StopFlag()
        self._timing_capacity = timing_capacity
        self.triggered = False  # mode wait_for_trigger: activated
        # the hardware's feeder: controllers of a hardware that failed are deactivated
        self.hardware_feeder: Callable[[], object] | None = None

    def not_ready_reason(self) -> str | None:
        s, n = self._settings, self._topology.count()  # (with lanes, every lane's count)
        if n == 0:
            return "no component is loaded"
        if s.mode == "wait_for_components" and n < s.num_components_expected:
            return (
                f"mode wait_for_components: {n} of the {s.num_components_expected} expected "
                "components are loaded (num_components_expected)"
            )
        if s.mode == "wait_for_trigger" and not self.triggered:
            return "mode wait_for_trigger: the loop has not been activated"
        return None

    def start_components(self) -> None:
        """Activate the components loaded since the loop last started, in execution order."""
        self._schedule.compiled()
        self._transitions.start(self._topology.graph.order)

    def run(
        self,
        iterations: int | None,
        on_iteration: Callable[[], object] | None,
        drain_logs_every_iteration: bool,
        timing_ring: Ring | None,
        feeders: Sequence[Callable[[], object]],
        ros_offset_ns: int | None,
    ) -> RunResult:
        """One run (see :meth:`Runner.run`)."""
        reason = self.not_ready_reason()
        if reason is not None:
            raise ConfigurationError(f"runner {self._name!r} cannot run: {reason}")
        executor = self._schedule.compiled()
        self.start_components()
        labels = self._schedule.labels
        aggregate = None
        if timing_ring is None:
            timing_ring = local_ring(len(labels), self._timing_capacity)
            aggregate = TimingAggregate()
        writer = TimingWriter(labels, timing_ring)
        executor.timing = writer
        watch = self._deadlines
        events_before = len(watch.events)
        # last: after the middleware's messages, before the first update
        hardware = (self.hardware_feeder,) if self.hardware_feeder is not None else ()
        executor.feeders = (tuple(feeders) + hardware
                            + ((watch.gate,) if watch.refresh() else ()))
        executor.ros_offset_ns = ros_offset_ns
        executor.idle = self._idle_hook(
            on_iteration, drain_logs_every_iteration, aggregate, timing_ring
        )
        if self._owns_stop_flag:
            self.stop_flag.clear()
        ran = 0
        containment = self._containment
        faults_before = len(containment.faults)
        containment.safe_stops = []
        try:
            while True:
                first = self._state.iteration + 1
                try:
                    left = None if iterations is None else iterations - ran
                    ran += executor.run(left, self.stop_flag)
                    break
                except UpdateFailure as failure:
                    ran += failure.iteration - first + 1  # the failed one used its slot
                    containment.contain(failure)  # raises when the loop must end
                    if iterations is not None and ran >= iterations:
                        break
                except WatchdogTripped as trip:
                    if not containment.contain_let_overruns(trip):
                        raise
                    ran += trip.iteration - first + 1
                    if iterations is not None and ran >= iterations:
                        break
        except WatchdogTripped as trip:
            self._notices.drain()
            containment.safe_stop(trip.describe())
            lane = self._schedule.lane
            where = f", lane {lane!r}" if lane not in (None, "", MAIN_LANE) else ""
            raise LoopError(f"runner {self._name!r}{where}: {trip.describe()}") from None
        finally:
            executor.idle = None
            executor.timing = None
            executor.feeders = ()
            executor.ros_offset_ns = None
            writer.release()
        self._notices.drain()
        stopped_by = "count" if iterations is not None and ran >= iterations else "stop"
        if self.stop_flag.cell[0] == ABORT:
            stopped_by = "abort"
            containment.safe_stop("the loop was stopped abnormally (a signal, or the supervisor)")
        if aggregate is not None:
            aggregate.finish(timing_ring, self._schedule.labels)
            timing = aggregate.summary(writer.count, writer.overruns)
        else:
            timing = TimingSummary(iterations=writer.count, samples=0, overruns=writer.overruns)
        return RunResult(
            iterations=ran,
            stopped_by=stopped_by,
            timing=timing,
            order=list(self._topology.graph.order),
            log_records_dropped=self._notices.ring.dropped,
            simulated=bool(getattr(self._clock, "simulated", False)),
            aggregate=aggregate,
            faults=containment.faults[faults_before:],
            safe_stops=list(containment.safe_stops),
            deadlines=watch.summary(),
            deadline_events=watch.events[events_before:],
            command_limits={g.port.qualified_name: g.summary()
                            for g in self._schedule.guards()},
        )

    def _idle_hook(
        self,
        on_iteration: Callable[[], object] | None,
        drain: bool,
        aggregate: TimingAggregate | None,
        timing_ring: Ring,
    ) -> Callable[[], object] | None:
        ring = self._notices.ring if isinstance(self._notices.ring, LogRing) else None
        sink = self._notices.sink
        names = self._schedule.labels
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
