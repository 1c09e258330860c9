"""One run of one worker, on the supervisor's side: its segments, from prepare to close.

A run has a timing ring (rows aggregated into histograms as they are drained), a
segment of channels for the mapped ports (a ring per output, a mailbox per input;
the bridge serves them) and, when recording, the recording's rings. The supervisor
opens them before the run, drains them while it runs, and says at its end what the
channels dropped or replaced.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from .._core._deadlines import DeadlineEvent
from .._core._faults import Fault, SafeStopOutcome
from .._core._lane_names import MAIN_LANE
from .._core._log import LogRecord
from .._core._rings import Mailbox, Ring
from .._core._runner import RunResult
from .._core._settings import RunnerSettings
from .._core._timing import (
    CONSUME_BATCH,
    TimingAggregate,
    TimingSummary,
    ring_capacity,
    row_size,
)
from ._port_channels import MailboxFanOut, MappedPort, create_channel, segment_size
from ._recording import RecordedTopic, RecordingDrain, RecordSink
from ._recording import segment_size as recording_segment_size
from ._shm import Segment
from ._worker_process import WorkerProcess

PUMP_ROWS = 8 * CONSUME_BATCH  # timing rows aggregated per pump, at most
PUMP_RECORDS = CONSUME_BATCH  # recorded values written per topic and pump, at most


@dataclass
class Run:
    """One run's channels on the supervisor's side, from prepare to close."""

    schedule: list[str]
    ports: list[MappedPort]
    recorded: list[RecordedTopic]
    record: RecordSink | None
    ros_offset: int
    seg: Segment | None = None
    ring: Ring | None = None
    aggregate: TimingAggregate = dataclasses.field(default_factory=TimingAggregate)
    port_seg: Segment | None = None
    channels: dict[str, Ring | Mailbox] = dataclasses.field(default_factory=dict)
    rec_seg: Segment | None = None
    drain: RecordingDrain | None = None
    done: dict[str, Any] | None = None
    arrived: dict[str, int] = dataclasses.field(default_factory=dict)  # per mapped input


def note(level: int, text: str) -> LogRecord:
    """A line of the supervisor's own in the log (as "rt_runner")."""
    return LogRecord(level, "rt_runner", text)


def chain_rows(
    previous: Callable[[Any], None] | None, then: Callable[[Any], None]
) -> Callable[[Any], None]:
    def on_rows(rows: Any) -> None:
        if previous is not None:
            previous(rows)
        then(rows)

    return on_rows


def with_timing_rows(
    previous: Callable[[Any], None] | None, record: Any, offset_ns: int
) -> Callable[[Any], None]:
    """The timing rows to the recording (iteration_info) as well as where they went."""
    return chain_rows(previous, lambda rows: record.timing_rows(rows, offset_ns))


def counts_only(timing: TimingSummary) -> TimingSummary:
    """On a simulated clock, the measured times mean nothing: keep only the counts."""
    return TimingSummary(iterations=timing.iterations, samples=0, overruns=timing.overruns)


class RunBridge(Protocol):
    """What a run asks of a middleware bridge: serve the mapped ports' channels, and
    take the timing rows (iteration_info)."""

    def open(
        self, ports: list[MappedPort], channels: Mapping[str, Ring | Mailbox | MailboxFanOut]
    ) -> None: ...

    def close_run(self) -> None: ...

    def iteration_info(self, rows: Any) -> None: ...


class RunChannels:
    """The runs of one worker, one at a time: the segments of the run under way and
    what drains them. ``call`` is the runner's control channel (its status line ticks
    while the run waits); ``bridge``, the runner's (the main lane's), serves the run's
    mapped ports; ``bridged``: whether a bridge serves them (a lane's worker's are
    served by the main lane's)."""

    def __init__(
        self,
        process: WorkerProcess,
        call: Callable[..., Any],
        settings: RunnerSettings,
        *,
        lane: str,
        simulated: bool,
        log_sink: Callable[[LogRecord], None],
        bridge: RunBridge | None,
        bridged: bool,
    ) -> None:
        self._process = process
        self.call = call
        self.settings = settings
        self.lane = lane
        self.simulated = simulated
        self.log_sink = log_sink
        self.bridge = bridge
        self.bridged = bridged
        # while a run is under way: its timing ring, schedule and aggregate, and the
        # recording's drain and sink
        self._timing: tuple[Ring, list[str], TimingAggregate] | None = None
        self._recording: tuple[RecordingDrain, RecordSink] | None = None
        # the worker's inputs with a deadline, in the order of its CTL_DEADLINES bits
        self.deadline_names: list[str] = []

    @property
    def running(self) -> bool:
        return self._timing is not None

    @property
    def aggregate(self) -> TimingAggregate | None:
        """The timing of the run under way (None between runs)."""
        return self._timing[2] if self._timing is not None else None

    def drain(self) -> None:
        """Aggregate timing rows and write recorded values (non-real-time, often)."""
        if self._timing is not None:
            ring, names, aggregate = self._timing
            # a bounded share each time: a supervisor that falls behind its rows must
            # still beat its heartbeat and serve requests (the ring counts what it drops)
            aggregate.consume(ring, names, PUMP_ROWS)
        if self._recording is not None:
            drain, recording = self._recording
            drain.drain(recording.write, PUMP_RECORDS)

    def ros_offset(self) -> int:
        """What turns a timing row's scheduled start into ROS time: 0 on a simulated
        clock and on /clock time, else wall minus monotonic (taken once per run)."""
        if self.simulated or self.settings.use_sim_time:
            return 0
        return time.time_ns() - time.monotonic_ns()

    def run(
        self, iterations: int | None, trace: str | None, record: RecordSink | None
    ) -> RunResult:
        """One run of this worker alone, its mapped ports served by the bridge."""
        run = self.open(self.prepare(record), record, self.ros_offset())
        try:
            if self.bridge is not None and run.ports:
                self.bridge.open(run.ports, run.channels)
            done = self.call_run(run, iterations, trace, None)
        finally:
            if self.bridge is not None and run.ports:
                self.bridge.close_run()
            self.close(run)
        return self.result(run, done)

    def prepare(self, record: RecordSink | None) -> dict[str, Any]:
        """Compile the worker's schedule: its mapped ports and recorded topics."""
        return self.call(
            "prepare", self.bridged, record.pattern if record is not None else None
        )

    def open(self, prepared: dict[str, Any], record: RecordSink | None, ros_offset: int) -> Run:
        """A run's segments: timing, the mapped ports' channels, the recording's rings."""
        schedule: list[str] = prepared["schedule"]
        ports: list[MappedPort] = prepared["ports"]
        recorded: list[RecordedTopic] = prepared["recorded"]
        run = Run(schedule, ports, recorded, record, ros_offset)
        self.deadline_names = list(prepared.get("deadlines", []))
        if record is not None and recorded:
            record.begin(recorded)
            run.rec_seg = self._process.segment(recording_segment_size(recorded), "rtcf-record")
            run.drain = RecordingDrain(run.rec_seg.buf, recorded)
            self._recording = (run.drain, record)
        capacity = ring_capacity(len(schedule))
        run.seg = self._process.segment(
            Ring.nbytes(capacity, row_size(len(schedule))), "rtcf-timing"
        )
        run.ring = Ring.create(run.seg.buf, capacity, row_size(len(schedule)))
        run.port_seg, run.channels = self._port_channels(ports)
        if self.bridge is not None and self.settings.iteration_info:
            run.aggregate.on_rows = self.bridge.iteration_info
        # wall minus monotonic, once per run, for the loop and the recording alike: every
        # recorded channel, the timing rows too, is stamped with the same offset
        if record is not None and hasattr(record, "timing_rows") and self.lane == MAIN_LANE:
            run.aggregate.on_rows = with_timing_rows(run.aggregate.on_rows, record, ros_offset)
        self._timing = (run.ring, schedule, run.aggregate)
        self._process.running = (schedule, run.aggregate)
        return run

    def call_run(
        self, run: Run, iterations: int | None, trace: str | None, lane_run: int | None
    ) -> dict[str, Any]:
        offset = None if self.simulated or self.settings.use_sim_time else run.ros_offset
        done: dict[str, Any] = self.call(
            "run", iterations, run.seg, trace, run.port_seg, run.ports, run.rec_seg,
            run.recorded or None, offset, lane_run,
        )
        run.done = done
        return done

    def close(self, run: Run) -> None:
        """Drain what is left and let go of the run's segments (the bridge is closed)."""
        self._timing = None
        self._process.running = None
        self._recording = None
        record = run.record
        if run.drain is not None and record is not None and run.rec_seg is not None:
            run.drain.drain(record.write)
            record.end_run(run.drain.dropped(), {})
            run.drain.close()
            self._process.close_segment(run.rec_seg)
        if run.ring is not None and run.seg is not None:
            run.aggregate.finish(run.ring, run.schedule)
            run.ring.close()
            self._process.close_segment(run.seg)
        run.arrived = {t: c.version for t, c in run.channels.items() if isinstance(c, Mailbox)}
        for topic, channel in run.channels.items():
            if isinstance(channel, Ring) and channel.dropped:
                self.log_sink(note(30, f"{channel.dropped} messages on {topic} were dropped: "
                                        "the channel to the middleware was full"))
            channel.close()
        if run.port_seg is not None:
            self._process.close_segment(run.port_seg)
        done = run.done
        if done is None:
            return
        if record is not None:
            record.end_run({}, done.get("recording", {}))
        for topic, n in done.get("oversize", {}).items():
            self.log_sink(note(30, f"{n} messages on {topic} were larger than a channel record "
                                    "and were not published"))
        for topic, n in sorted(done.get("inputs", {}).items()):
            arrived, superseded = run.arrived.get(topic, 0), n["superseded"]
            if superseded:  # the meaning of a mapped input (the latest value), said once
                self.log_sink(note(20, f"{superseded} of {arrived} messages on {topic} were "
                                        "replaced by a newer one before an iteration read "
                                        "them (a mapped input holds the latest value)"))

    def result(self, run: Run, done: dict[str, Any]) -> RunResult:
        aggregate = run.aggregate
        timing = aggregate.summary(done["rows"], done["overruns"])
        return RunResult(
            iterations=done["iterations"],
            stopped_by=done["stopped_by"],
            timing=timing if not done["simulated"] else counts_only(timing),
            order=done["order"],
            log_records_dropped=self._process.log_records_dropped,
            simulated=done["simulated"],
            realtime=done["realtime"],
            aggregate=aggregate,
            faults=[Fault(**f) for f in done.get("faults", [])],
            safe_stops=[SafeStopOutcome(**o) for o in done.get("safe_stops", [])],
            lanes={self.lane: {"handovers": done.get("handovers", {}),
                               "missed": done.get("missed", 0)}},
            inputs={t: {"arrived": run.arrived.get(t, 0), **n}
                    for t, n in sorted(done.get("inputs", {}).items())},
            deadlines=done.get("deadlines", {}),
            deadline_events=[DeadlineEvent(**e) for e in done.get("deadline_events", [])],
            command_limits=done.get("command_limits", {}),
        )

    def _port_channels(
        self, ports: list[MappedPort]
    ) -> tuple[Segment | None, dict[str, Ring | Mailbox]]:
        """One segment holding a ring per mapped output and a mailbox per mapped input."""
        if not ports:
            return None, {}
        seg = self._process.segment(segment_size(ports), "rtcf-ports")
        channels: dict[str, Ring | Mailbox] = {}
        for p in ports:
            view = seg.buf[p.offset : p.offset + p.nbytes]
            channels[p.topic] = create_channel(view, p)
            view.release()
        return seg, channels
