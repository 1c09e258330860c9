"""The workers of a runner's other lanes, started by its main lane and run with it.

A lane other than main runs in a worker process of its own (Decision 7). The main
lane's supervisor starts one per lane on first use, pinned where the lanes parameter
or the default placement says; routes each component's requests to its lane; lays
out the topics that cross lanes in one shared segment; and runs every lane's worker
together, the others in threads of their own, the first failure stopping them all.
"""

from __future__ import annotations

import threading
from typing import Any

from .._core._errors import ConfigurationError
from .._core._lane_names import MAIN_LANE
from .._core._rings import Mailbox, Ring
from .._core._runner import RunResult
from .._core._timing import LoopSpan, TimingAggregate, TimingSummary
from ._port_channels import MailboxFanOut, MappedPort
from ._recording import RecordedTopic, RecordSink, relaid
from ._runs import Run


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
