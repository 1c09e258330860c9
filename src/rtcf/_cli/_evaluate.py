"""``rtcf evaluate RECORDING FREQUENCY``: the original's ``evaluate_performance_rosbag``.

Reads a runner's ``iteration_info`` from a recording and draws the paper's Fig. 2:
histograms of the calculation time and of the timing of the iterations' starts,
with their 99.9 % quantile and maximum, and prints the same figures.

One reader per recording format turns a file into
:class:`~rtcf._core._iteration_records.IterationRecords`; everything after that is
the same for every format:

* ``.bag``: a ROS 1 bag (``rosbag record /rt_runner/iteration_info``), read with
  Debian's rosbag (:mod:`rtcf._ros1._bag`).
* ``.mcap``: rtcf's own recordings (``rtcf launch --record``, which records the
  timing rows as ``<runner>/iteration_info``) and rosbag2's MCAP of
  ``~/iteration_info``.

The right panel depends on what the messages carry. The original's
``rtcf_msgs/IterationInfo`` stamps when each iteration started: as the original's
script did, rtcf takes every interval between consecutive starts and shows how far
it is from the period (1/FREQUENCY), ``|interval - period|``. A late start shows
twice: a long interval, then (``wait_policy: absolute``) short ones while the loop
catches up. A message missing from the recording, or the loop paused for a load,
shows as a long interval too: those longer than 1.5 periods are counted and said.
The ``Float64MultiArray`` form carries the wake-up jitter itself and the iteration
number, so it is shown as it is, and missing messages are known.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._core._errors import RtcfError
from .._core._histogram import LogHistogram
from .._core._iteration_records import IterationRecords

Reader = Callable[[str, "str | None"], IterationRecords]
INTERVAL_DEVIATION = "|start-to-start interval - period|"
WAKE_UP_JITTER = "wake-up jitter"


def _read_ros1_bag(path: str, topic: str | None) -> IterationRecords:
    from .._ros1._bag import read_iteration_info

    return read_iteration_info(path, topic)


def _read_mcap(path: str, topic: str | None) -> IterationRecords:
    """iteration_info from an MCAP file: rtcf's own recording (``rtcf launch --record``:
    the topic its metadata names) or rosbag2's (``ros2 bag record -s mcap
    /rt_runner/iteration_info``), std_msgs/msg/Float64MultiArray in both."""
    from .._runtime._recording_reader import read

    rec = read(
        path, (lambda t: t == topic) if topic else (lambda t: t.endswith("/iteration_info"))
    )
    infos = sorted(rec.messages)
    chosen = topic or rec.metadata.get("timing_topic") or (infos[0] if len(infos) == 1 else None)
    if chosen is None:
        raise RtcfError(
            f"{path}: " + (
                f"several iteration_info topics ({', '.join(infos)}); pick one with --topic"
                if infos else "no iteration_info topic in it; record one with rtcf launch "
                "--record, or ros2 bag record -s mcap /rt_runner/iteration_info"
            )
        )
    columns: list[list[int]] = [[], [], [], []]
    if chosen in rec.messages:
        decode = rec.decoder(chosen)
        for message in rec.messages[chosen]:
            it, stamp, calc, jitter = list(decode(message.data).data)[:4]
            columns[0].append(int(it))
            columns[1].append(round(stamp * 1e9))
            columns[2].append(round(calc * 1e9))
            columns[3].append(round(jitter * 1e9))
    it_ns, stamp_ns, calc_ns, jitter_ns = (np.array(c, dtype=np.int64) for c in columns)
    return IterationRecords(
        path, chosen, "std_msgs/msg/Float64MultiArray", stamp_ns, calc_ns, jitter_ns, it_ns
    )


# one reader per format, chosen by the file's suffix
READERS: dict[str, Reader] = {".bag": _read_ros1_bag, ".mcap": _read_mcap}


def read_recording(path: str, topic: str | None = None) -> IterationRecords:
    suffix = Path(path).suffix.lower()
    reader = READERS.get(suffix)
    if reader is None:
        known = ", ".join(sorted(READERS))
        raise RtcfError(f"{path}: no reader for {suffix or 'files without a suffix'} ({known})")
    return reader(path, topic)


@dataclass
class Evaluation:
    """What ``rtcf evaluate`` shows of one recording."""

    records: IterationRecords
    frequency: float
    calc: LogHistogram
    starts: LogHistogram  # the right panel: see :attr:`starts_name`
    starts_name: str
    long_intervals: int  # longer than 1.5 periods: late starts, missing messages, pauses
    missing: int | None  # messages missing from the recording, where iterations say so
    overruns: int  # iterations that ended after the next one was due
    span_s: float  # from the first start to the last
    median_interval_ns: float

    def summary(self) -> dict[str, Any]:
        return {
            "source": self.records.source,
            "topic": self.records.topic,
            "type": self.records.msg_type,
            "frequency_hz": self.frequency,
            "samples": len(self.records),
            "span_s": self.span_s,
            "median_interval_us": self.median_interval_ns / 1e3,
            "long_intervals": self.long_intervals,
            "missing": self.missing,
            "overruns": self.overruns,
            "calc_us": self.calc.summary_us(),
            "starts": self.starts_name,
            "starts_us": self.starts.summary_us(),
        }


def evaluate(records: IterationRecords, frequency: float) -> Evaluation:
    n = len(records)
    if n < 2:
        raise RtcfError(
            f"{records.source}: {records.topic} holds {n} message{'' if n == 1 else 's'}; "
            "at least two are needed"
        )
    order = np.argsort(records.stamp_ns, kind="stable")
    stamps = records.stamp_ns[order]
    calc_ns = records.calc_ns[order]
    period = round(1e9 / frequency)
    intervals = np.diff(stamps)
    missing = None
    if records.iteration is not None:
        missing = int((np.diff(records.iteration[order]) - 1).clip(min=0).sum())
    calc = LogHistogram()
    calc.add(calc_ns)
    starts = LogHistogram()
    if records.jitter_ns is not None:
        jitter = records.jitter_ns[order]
        starts.add(jitter)
        name = WAKE_UP_JITTER
        overruns = int(((jitter + calc_ns) > period).sum())
    else:
        starts.add(np.abs(intervals - period))
        name = INTERVAL_DEVIATION
        overruns = int((calc_ns > period).sum())
    return Evaluation(
        records=records,
        frequency=frequency,
        calc=calc,
        starts=starts,
        starts_name=name,
        long_intervals=int((intervals > period + period // 2).sum()),
        missing=missing,
        overruns=overruns,
        span_s=float(stamps[-1] - stamps[0]) / 1e9,
        median_interval_ns=float(np.median(intervals)),
    )


def format_evaluation(ev: Evaluation) -> str:
    r = ev.records
    lines = [
        f"{r.source}: {len(r):,} iterations on {r.topic} ({r.msg_type}) over "
        f"{ev.span_s:.3f} s at {ev.frequency:g} Hz; overruns: {ev.overruns}"
    ]
    labels = ("min", "p50", "p99", "p99.9", "max")
    keys = ("min", "p50", "p99", "p999", "max")
    lines.append("  {:<38}".format("timing [µs]") + "".join(f"{c:>10}" for c in labels))
    for label, hist in (("calculation", ev.calc), (ev.starts_name, ev.starts)):
        stats = hist.summary_us()
        lines.append(
            f"  {label:<38}" + "".join(f"{stats.get(k, float('nan')):>10.1f}" for k in keys)
        )
    if ev.missing:
        lines.append(f"  ({ev.missing} iterations are missing from the recording)")
    if ev.long_intervals and ev.records.jitter_ns is None:
        lines.append(
            f"  ({ev.long_intervals} start-to-start interval"
            f"{'' if ev.long_intervals == 1 else 's'} longer than 1.5 periods: late starts, "
            "or messages missing from the recording, or the loop paused for a load)"
        )
    period_ns = 1e9 / ev.frequency
    if abs(ev.median_interval_ns - period_ns) > 0.1 * period_ns:
        lines.append(
            f"  warning: FREQUENCY {ev.frequency:g} Hz means {period_ns / 1e3:.1f} µs, but the "
            f"median interval is {ev.median_interval_ns / 1e3:.1f} µs: is FREQUENCY the "
            "runner's?"
        )
    return "\n".join(lines)


def plot_evaluation(ev: Evaluation, out: Path) -> Path:
    from ._plot import plot_timing  # matplotlib only when a plot is drawn

    r = ev.records
    return plot_timing(
        out,
        ev.calc,
        ev.starts,
        title=(
            f"{Path(r.source).name}: {len(r):,} iterations at {ev.frequency:g} Hz "
            f"({ev.span_s:.0f} s)"
        ),
        subtitle=(
            f"{r.topic} ({r.msg_type}); overruns {ev.overruns}; "
            f"{ev.long_intervals} intervals over 1.5 periods"
        ),
        names=("calculation time", ev.starts_name),
    )


def cmd_evaluate(ns: argparse.Namespace) -> int:
    records = read_recording(ns.recording, ns.topic)
    ev = evaluate(records, ns.frequency)
    out = Path(ns.output) if ns.output else Path(f"{ns.recording}.evaluation.png")
    written = None if ns.no_plot else plot_evaluation(ev, out)
    if ns.json:
        doc = ev.summary()
        doc["plot"] = str(written) if written else None
        print(json.dumps(doc, indent=2))
    else:
        print(format_evaluation(ev), flush=True)
    if written is not None:
        print(f"rtcf: wrote {written}", file=sys.stderr, flush=True)
    return 0


def add_parser(sub: Any, add_debug: Callable[[argparse.ArgumentParser], None]) -> None:
    p = sub.add_parser(
        "evaluate",
        help="plot a recording's iteration_info (the paper's Fig. 2)",
        description=(
            "Read a runner's iteration_info from a recording (a ROS 1 bag: rosbag record "
            "/rt_runner/iteration_info) and plot histograms of the calculation time and of "
            "the iterations' start times, as the original's evaluate_performance_rosbag."
        ),
    )
    p.add_argument("recording", metavar="RECORDING", help="a ROS 1 bag (.bag)")
    p.add_argument("frequency", metavar="FREQUENCY", type=_frequency,
                   help="the runner's frequency in Hz")
    p.add_argument("--topic", help="the iteration_info topic (default: the one in the file)")
    p.add_argument("--output", metavar="PNG",
                   help="where to write the plot (default: RECORDING.evaluation.png)")
    p.add_argument("--no-plot", action="store_true", help="print the figures only")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(func=cmd_evaluate, log_level="warning")
    add_debug(p)


def _frequency(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a frequency in Hz") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text} is not a positive frequency in Hz")
    return value
