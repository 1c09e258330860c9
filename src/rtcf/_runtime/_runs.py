"""One run of one worker, on the supervisor's side: its segments, from prepare to close.

A run has a timing ring (rows aggregated into histograms as they are drained), a
segment of channels for the mapped ports (a ring per output, a mailbox per input;
the bridge serves them) and, when recording, the recording's rings. The supervisor
opens them before the run, drains them while it runs, and says at its end what the
channels dropped or replaced.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .._core._log import LogRecord
from .._core._rings import Mailbox, Ring
from .._core._timing import TimingAggregate, TimingSummary
from ._port_channels import MappedPort
from ._recording import RecordedTopic, RecordingDrain, RecordSink
from ._shm import Segment


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
