"""The workers of a runner's other lanes, started by its main lane and run with it.

A lane other than main runs in a worker process of its own (Decision 7). The main
lane's supervisor starts one per lane on first use, pinned where the lanes parameter
or the default placement says; routes each component's requests to its lane; lays
out the topics that cross lanes in one shared segment; and runs every lane's worker
together, the others in threads of their own, the first failure stopping them all.
"""

from __future__ import annotations

import dataclasses
import os
import threading
import time
from collections.abc import Callable
from typing import Any, Generic, Protocol, TypeVar

from .._core._errors import ConfigurationError, RtcfError
from .._core._lane_names import MAIN_LANE
from .._core._log import LogRecord
from .._core._rings import Mailbox, Ring
from .._core._runner import RunResult
from .._core._settings import RunnerSettings, lane_placement
from .._core._timing import LoopSpan, TimingAggregate, TimingSummary
from ._lanes import LaneLayout, abort_all, init_words, layout, reset_stop
from ._port_channels import MailboxFanOut, MappedPort
from ._recording import RecordedTopic, RecordSink, relaid
from ._runs import Run, RunBridge, RunChannels, chain_rows, note
from ._shm import Segment
from ._worker_process import POLL_S


def share_out(prepared: dict[str, dict[str, Any]]) -> None:
    """Each recorded topic in one lane only (a mapped input several lanes read is fed
    in each); a mapped output written in several lanes is a clear error."""
    published: dict[str, str] = {}
    recorded: set[str] = set()
    for lane, p in prepared.items():
        for port in p["ports"]:
            if port.direction != "output":
                continue
            if port.topic in published:
                raise ConfigurationError(
                    f"topic {port.topic!r} is mapped to the middleware and written in lanes "
                    f"{published[port.topic]!r} and {lane!r}: one lane must own a published "
                    "topic; put its writers (a component and its fallback) in one lane"
                )
            published[port.topic] = lane
        mine = [t for t in p["recorded"] if t.topic not in recorded]
        recorded.update(t.topic for t in mine)
        p["recorded"] = relaid(mine)


def bridged_channels(
    runs: dict[str, Run],
) -> tuple[list[MappedPort], dict[str, Ring | Mailbox | MailboxFanOut]]:
    """Every lane's mapped ports as one bridge sees them: an input several lanes read
    is one subscription that feeds each lane's mailbox."""
    ports: dict[str, MappedPort] = {}
    boxes: dict[str, list[Mailbox]] = {}
    channels: dict[str, Ring | Mailbox | MailboxFanOut] = {}
    for run in runs.values():
        for port in run.ports:
            channel = run.channels[port.topic]
            if port.direction == "input":
                assert isinstance(channel, Mailbox)
                boxes.setdefault(port.topic, []).append(channel)
            else:
                channels[port.topic] = channel
            ports.setdefault(port.topic, port)
    for topic, found in boxes.items():
        channels[topic] = found[0] if len(found) == 1 else MailboxFanOut(found)
    return list(ports.values()), channels


def merge_connections(
    first: list[dict[str, Any]], second: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Two lanes' introspected connections as one list, by topic."""
    out = {c["topic"]: dict(c, publishers=list(c["publishers"]),
                            subscribers=list(c["subscribers"])) for c in first}
    for c in second:
        mine = out.setdefault(c["topic"], dict(c, publishers=[], subscribers=[]))
        mine["publishers"] += c["publishers"]
        mine["subscribers"] += c["subscribers"]
    return [out[t] for t in sorted(out)]


class LockedSink:
    """A record sink that the lanes' threads share: one writer at a time."""

    def __init__(self, sink: RecordSink) -> None:
        self._sink = sink
        self._lock = threading.Lock()
        self.pattern = sink.pattern
        if hasattr(sink, "timing_rows"):
            self.timing_rows = self._timing_rows

    def begin(self, topics: list[RecordedTopic]) -> None:
        with self._lock:
            self._sink.begin(topics)

    def write(self, record: Any) -> None:
        with self._lock:
            self._sink.write(record)

    def end_run(self, dropped: dict[str, int], counts: dict[str, dict[str, int]]) -> None:
        with self._lock:
            self._sink.end_run(dropped, counts)

    def _timing_rows(self, rows: Any, offset_ns: int) -> None:
        with self._lock:
            self._sink.timing_rows(rows, offset_ns)  # type: ignore[attr-defined]


def whole_loop(
    main: RunResult, results: dict[str, RunResult], span: LoopSpan, lock_step: list[str]
) -> tuple[TimingAggregate | None, TimingSummary]:
    """The run's top-level timing with lanes: the loop as a whole (from the first
    lock-step lane's start to the last one's end), every lane's components (the
    main lane's handovers too: how long it waited for the others)."""
    if main.aggregate is None or main.simulated:
        return main.aggregate, main.timing
    whole = span.snapshot(main.aggregate)
    for name, result in results.items():
        if name != MAIN_LANE and result.aggregate is not None:
            for label, hist in result.aggregate.components.items():
                if not label.startswith("@"):
                    whole.components.setdefault(label, hist)
    if len(lock_step) == 1:  # the other lanes are on LET: the loop is the main lane
        whole.phases = main.aggregate.phases
    return whole, whole.summary(main.timing.iterations, span.overruns)


class LaneWorker(Protocol):
    """What the lanes ask of a lane's worker (a WorkerRunner), the main lane's too."""

    components: dict[str, dict[str, Any]]

    @property
    def introspection(self) -> dict[str, Any]: ...

    @property
    def pid(self) -> int | None: ...

    def call(self, command: str, *args: Any) -> Any: ...

    def pump(self) -> None: ...

    def request_stop(self, *, abort: bool = False) -> None: ...

    @property
    def runs(self) -> RunChannels: ...


W = TypeVar("W", bound=LaneWorker)


class LaneWorkers(Generic[W]):
    """The main lane's runner's workers of the other lanes, and what runs them with it.

    ``start(lane, settings)`` makes and starts a lane's worker (pinned by
    ``settings``); ``segment`` and ``close_segment`` are the main lane's worker's
    (the lanes' segment goes wherever its segments go). The methods that run every
    lane take the main lane's worker (``main``): it runs with the others, the same
    verbs, and no lane worker holds it.
    """

    def __init__(
        self,
        settings: RunnerSettings,
        name: str,
        log_sink: Callable[[LogRecord], None],
        *,
        start: Callable[[str, RunnerSettings], W],
        segment: Callable[[int, str], Segment],
        close_segment: Callable[[Segment], None],
    ) -> None:
        self.settings = settings
        self.name = name
        self.log_sink = log_sink
        self._start = start
        self._segment = segment
        self._close_segment = close_segment
        self.workers: dict[str, W] = {}
        self.lane_of: dict[str, str] = {}  # component -> lane (other than main)
        self._seg: Segment | None = None
        self._layout: LaneLayout | None = None
        self._runs = 0
        self.placement: dict[str, str] = {}  # lane -> where it runs, said once
        self.say = True  # in the log at info level (rtcf launch says it itself)
        self.span: LoopSpan | None = None  # while lanes run: the loop as a whole

    def other_lane(self, component: str) -> str | None:
        """The lane other than main that runs ``component`` (None: the main lane)."""
        return self.lane_of.get(component if component.startswith("/") else "/" + component)

    def said(self, component: str) -> str:
        """Where a component runs, for a "loaded" line: "" in the main lane, else
        " in lane 'x' (pid, CPU, priority)"."""
        lane = self.other_lane(component)
        if lane is None:
            return ""
        return f" in lane {lane!r} ({self.placement.get(lane, '')})"

    def worker_of(self, component: str) -> W | None:
        """The worker of the lane other than main that runs ``component``."""
        lane = self.other_lane(component)
        return self.workers[lane] if lane is not None else None

    def worker(self, lane: str) -> W:
        """The worker of lane ``lane``, started on first use, pinned where the lanes
        parameter or the default placement says (and said once, in the log)."""
        worker = self.workers.get(lane)
        if worker is not None:
            return worker
        names = [*self.workers, lane]
        allowed = sorted(os.sched_getaffinity(0))
        mask, priority, how = lane_placement(self.settings, names, allowed)[lane]
        settings = dataclasses.replace(
            self.settings, cpu_affinity_mask=mask, priority=priority, notes=[],
            # the hardware is the main lane's worker's alone (read, write, claims)
            robot_description="", robot_description_file=""
        )
        worker = self._start(lane, settings)
        self.workers[lane] = worker
        self.placement[lane] = f"pid {worker.pid}, {how}, priority {priority}"
        said = (f"lane {lane!r} runs in a worker process of its own (pid {worker.pid}) on "
                f"{how}, priority {priority}")
        self.log_sink(note(20 if self.say else 10, said))
        return worker

    def running(self, main: W) -> dict[str, W]:
        return {MAIN_LANE: main, **{n: w for n, w in self.workers.items() if w.components}}

    def merge_introspection(self, data: dict[str, Any]) -> dict[str, Any]:
        """The main lane's introspection data with every other lane's components and
        connections."""
        for worker in self.workers.values():
            more = worker.introspection
            data["components"] = list(data.get("components", [])) + list(more["components"])
            data["connections"] = merge_connections(
                data.get("connections", []), more.get("connections", [])
            )
        return data

    def merge_described(self, out: dict[str, Any]) -> dict[str, Any]:
        """The main lane's description with every other lane's components."""
        for worker in self.workers.values():
            out["components"] = list(out["components"]) + list(worker.components)
        return out

    def close(self) -> None:
        """Let go of the lanes' segment (their workers are closed)."""
        if self._seg is not None:
            self._seg.close()
            self._seg = None

    def sync(self, main: W, *, mirror: bool) -> dict[str, dict[str, Any]]:
        """Tell every lane's worker the other lanes' components (and, to trace them,
        that the main lane receives every topic); answer what each hands over."""
        workers = self.running(main)
        facts = {lane: w.call("lane_facts") for lane, w in workers.items()}
        topics = sorted(
            {p.topic for f in facts.values() for n in f["nodes"] for p in n.outputs}
        ) if mirror else []
        replies = {}
        for lane, worker in workers.items():
            nodes = [n for other, f in facts.items() if other != lane for n in f["nodes"]]
            members = [m for other, f in facts.items() if other != lane for m in f["members"]]
            replies[lane] = worker.call("set_lanes", lane, nodes, members, topics)
        return replies

    def bind(self, main: W, trace: bool) -> None:
        """Lay the crossing topics out in one segment and hand it to every lane (a new
        one only when the layout changed: a delayed value survives a pause)."""
        replies = self.sync(main, mirror=trace)
        sends: dict[str, tuple[str, int]] = {}
        for reply in replies.values():
            sends.update(reply["sends"])
        lanes = replies[MAIN_LANE]["lanes"]
        missing = [n for n in lanes if n not in replies]
        if missing:  # a lane the plan knows but no worker runs: a bug
            raise RtcfError(f"runner {self.name!r}: no worker runs lane(s) {missing}")
        new = layout(lanes, sends)
        workers = self.running(main)
        if new != self._layout or self._seg is None:
            if self._seg is not None:
                self._close_segment(self._seg)
            seg = self._seg = self._segment(max(new.size, 4096), "rtcf-lanes")
            init_words(seg.buf, new)
            self._layout = new
            for lane in new.lanes:
                workers[lane].call("bind_lanes", seg.handle(), new)
        reset_stop(self._seg.buf)

    def abort(self, main: W) -> None:
        """A lane failed or died: the others stop at once, through their safe stops."""
        if self._seg is not None:
            abort_all(self._seg.buf)
        main.request_stop(abort=True)

    def run(
        self,
        main_worker: W,
        iterations: int | None,
        trace: str | None,
        record: RecordSink | None,
        *,
        bridge: RunBridge | None,
        ros_offset: int,
    ) -> RunResult:
        """Run every lane's worker together: the others in threads of their own (each
        drains its worker), the main lane here; the first failure stops them all. Each
        lane publishes and records its own topics; the bridge serves them all."""
        self.bind(main_worker, trace is not None)
        self._runs += 1
        lane_run = self._runs
        workers = self.running(main_worker)
        sink = LockedSink(record) if record is not None else None
        prepared = {name: w.runs.prepare(sink) for name, w in workers.items()}
        share_out(prepared)
        runs: dict[str, Run] = {}
        failures: list[tuple[float, BaseException]] = []
        results: dict[str, RunResult] = {}
        opened = False
        main: RunResult | None = None
        try:
            lay = self._layout
            every = {n: k[0] for n, k in zip(lay.lanes, lay.kinds, strict=True)} if lay else {}
            lock_step = [n for n in workers if every.get(n, 1) == 1]
            span = self.span = LoopSpan(len(lock_step), self.settings.period_ns)
            for name, w in workers.items():
                runs[name] = w.runs.open(prepared[name], sink, ros_offset)
                if name == MAIN_LANE:  # iteration_info and a recording's: the loop's rows
                    span.on_rows, runs[name].aggregate.on_rows = runs[name].aggregate.on_rows, None
                if name in lock_step:
                    runs[name].aggregate.on_rows = chain_rows(
                        runs[name].aggregate.on_rows, span.add
                    )
            ports, channels = bridged_channels(runs)
            if bridge is not None and ports:
                bridge.open(ports, channels)
                opened = True

            def lane(name: str, worker: W) -> None:
                try:
                    # (the main lane's count ends every lane after the same iteration)
                    done = worker.runs.call_run(runs[name], None, None, lane_run)
                    results[name] = worker.runs.result(runs[name], done)
                except BaseException as exc:
                    failures.append((time.monotonic(), exc))
                    self.abort(main_worker)

            threads = [
                threading.Thread(target=lane, args=(n, w), name=f"rtcf-lane-{n}", daemon=True)
                for n, w in workers.items()
                if w is not main_worker
            ]
            for t in threads:
                t.start()
            try:
                main = main_worker.runs.result(
                    runs[MAIN_LANE],
                    main_worker.runs.call_run(runs[MAIN_LANE], iterations, trace, lane_run),
                )
            except BaseException as exc:
                failures.append((time.monotonic(), exc))
                self.abort(main_worker)
            for t in threads:
                while t.is_alive():
                    t.join(POLL_S)
                    if main is None:
                        main_worker.pump()
        finally:
            self.span = None
            if opened and bridge is not None:
                bridge.close_run()
            for name, run in runs.items():
                workers[name].runs.close(run)
        if failures:
            raise min(failures, key=lambda f: f[0])[1]
        assert main is not None
        results = {MAIN_LANE: dataclasses.replace(main, lanes=dict(main.lanes)), **results}
        for name, result in results.items():
            main.lanes[name] = {
                "every": every.get(name, 1),
                "iterations": result.iterations,
                "stopped_by": result.stopped_by,
                "timing": result.timing,
                "aggregate": result.aggregate,
                "realtime": result.realtime,
                "placement": self.placement.get(name, ""),
                **result.lanes.get(name, {}),
            }
            if name == MAIN_LANE:
                cpus = (main.realtime or {}).get("cpu_affinity")
                where = (f"CPU{'s' if len(cpus) > 1 else ''} {', '.join(map(str, cpus))}"
                         if cpus else "not pinned")
                main.lanes[name]["placement"] = f"pid {main_worker.pid}, {where} (the runner's)"
                continue
            main.faults += result.faults
            main.deadlines.update(result.deadlines)
            main.command_limits.update(result.command_limits)
            main.deadline_events += result.deadline_events
            main.safe_stops += result.safe_stops
            if result.stopped_by == "abort" and main.stopped_by != "abort":
                main.stopped_by = "abort"
        main.aggregate, main.timing = whole_loop(main, results, span, lock_step)
        for name, info in main.lanes.items():
            for label, counts in info.get("handovers", {}).items():
                said = ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in counts.items())
                self.log_sink(note(30, f"lane {name!r}: {label}: {said}"))
            if info.get("missed"):
                self.log_sink(note(30, f"lane {name!r}: {info['missed']} releases skipped "
                                        "after overrunning its window (LET overruns)"))
        return main
