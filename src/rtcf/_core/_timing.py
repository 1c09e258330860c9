"""Timing of the loop: one row per iteration, written without allocation, aggregated later.

The loop (producer) writes every iteration's row into a :class:`~rtcf._core._rings.Ring`
of fixed-size int64 records: iteration, scheduled start, wake-up jitter, calculation
time, whether it overran, the phase of the hyperperiod (which plan ran: 0 when all
components run at the loop's rate), then one calculation time per scheduled
component (-1 in an iteration the component did not run in: inactive or not its
phase; not counted). In
the worker process the ring lives in shared memory and the supervisor drains it
(:class:`TimingAggregate`) into log-linear histograms, so a run of any length keeps
exact counts, min and max and quantiles within 0.8 %. A row that finds the ring
full is written to a scratch row instead and counted as dropped, never silently.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ._rings import Ring

if TYPE_CHECKING:  # the worker never imports numpy: its BLAS would start threads there
    from ._histogram import LogHistogram

QUANTILES = (("p50", 0.5), ("p90", 0.9), ("p99", 0.99), ("p999", 0.999))

# columns of a timing row; the components' calculation times follow. The scheduled
# start is on the loop's clock: CLOCK_MONOTONIC ns, or /clock ns under use_sim_time.
COL_ITERATION, COL_SCHEDULED, COL_JITTER, COL_CALC, COL_OVERRAN, COL_PHASE = range(6)
FIXED_COLUMNS = 6
# the columns a Calculation writes itself, in the order it takes them (the overrun is
# the executor's to write)
CALCULATION_COLUMNS = (COL_ITERATION, COL_SCHEDULED, COL_JITTER, COL_CALC, COL_PHASE)

# iteration_info as std_msgs/Float64MultiArray (ROS 2, and ROS 1 without rtcf_msgs):
# these four doubles per iteration, in seconds but for the iteration number
ITERATION_INFO_LABELS = ("iteration", "stamp", "calc_duration", "jitter")
ITERATION_INFO_BYTES = 32


def quantile(sorted_values: Sequence[int] | Sequence[float], q: float) -> float:
    """Nearest-rank quantile of already sorted values (the smallest v with F(v) >= q)."""
    if not sorted_values:
        return math.nan
    rank = max(1, math.ceil(q * len(sorted_values)))
    return float(sorted_values[min(rank, len(sorted_values)) - 1])


def summarize_ns(values: Sequence[int]) -> dict[str, float]:
    """min, p50, p90, p99, p99.9, max and mean of nanosecond samples, in microseconds."""
    if not values:
        return {}
    s = sorted(values)
    out = {"min": s[0] / 1e3}
    for key, q in QUANTILES:
        out[key] = quantile(s, q) / 1e3
    out["max"] = s[-1] / 1e3
    out["mean"] = sum(s) / len(s) / 1e3
    return out


def row_size(components: int) -> int:
    """Bytes of one timing row for ``components`` scheduled components."""
    return 8 * (FIXED_COLUMNS + components)


def local_ring(components: int, capacity: int = 1 << 12) -> Ring:
    """A timing ring in this process's memory (for a runner without a worker)."""
    size = row_size(components)
    return Ring.create(bytearray(Ring.nbytes(capacity, size)), capacity, size)


# Rows the supervisor takes from the ring at a time (about 20 every 10 ms at 2 kHz):
# each batch lives as numpy arrays and, for iteration_info, as Python lists for a
# moment, and a heap grown for one large batch does not shrink again.
CONSUME_BATCH = 512


def ring_capacity(components: int, budget_bytes: int = 16 << 20) -> int:
    """Rows that fit a memory budget: 16 MiB is 8 s of a 5-component loop at 2 kHz...

    ...and still 2048 rows for 1000 components; the supervisor drains every 10 ms.
    """
    rows = budget_bytes // row_size(components)
    capacity = 256
    while capacity * 2 <= rows and capacity < 1 << 16:
        capacity *= 2
    return capacity


def iteration_info_doubles(rows: Any, ros_offset_ns: int) -> bytes:
    """The iteration_info data of timing ``rows`` (an int64 array, one row each):
    [iteration, stamp (ROS time of the scheduled start), calc_duration, jitter] as
    little-endian doubles, :data:`ITERATION_INFO_BYTES` a row, rows one after another.

    One array for the batch, where a list per row would make a backlog (after a
    stall, up to a batch of 512 rows) a burst of Python objects that leaves
    CPython's heap larger for good. The same doubles as Python's float arithmetic on
    each row would give (the int64 sum is exact, its conversion rounds the same way).
    """
    import numpy as np

    out = np.empty((len(rows), 4), dtype="<f8")
    out[:, 0] = rows[:, COL_ITERATION]
    out[:, 1] = (rows[:, COL_SCHEDULED] + ros_offset_ns) * 1e-9
    out[:, 2] = rows[:, COL_CALC] * 1e-9
    out[:, 3] = rows[:, COL_JITTER] * 1e-9
    return out.tobytes()


class TimingWriter:
    """Producer side: what the executor needs to write rows into ``ring``."""

    def __init__(self, components: Sequence[str], ring: Ring) -> None:
        self.components = list(components)
        self.width = FIXED_COLUMNS + len(self.components)
        if ring.record_size < 8 * self.width:
            raise ValueError(
                f"timing ring rows hold {ring.record_size} bytes; {len(self.components)} "
                f"components need {8 * self.width}"
            )
        self.ring = ring
        self.words = ring.data.cast("q")
        self.scratch = array("q", bytes(8 * self.width))  # where a row goes when the ring is full
        self.count = 0  # rows written or dropped
        self.overruns = 0

    def release(self) -> None:
        """Let go of the view into the ring (so a shared segment can be closed)."""
        self.words.release()


class TimingAggregate:
    """Consumer side: histograms of jitter and calculation time, whole and per component."""

    def __init__(self) -> None:
        from ._histogram import LogHistogram

        self._new = LogHistogram
        self.jitter = LogHistogram()
        self.calc = LogHistogram()
        self.components: dict[str, LogHistogram] = {}
        # the iteration's calculation time per phase of the hyperperiod (which plan ran)
        self.phases: dict[int, LogHistogram] = {}
        self.rows = 0  # rows aggregated
        self.overruns = 0  # among the aggregated rows
        self.dropped = 0  # rows the loop could not write (ring full), from finished rings
        self.last_iteration = -1
        self.on_rows: Any = None  # called with every batch of rows (numpy int64, n x columns)
        self._columns: Any = None  # the components' histograms, counted as one block

    def consume(self, ring: Ring, components: Sequence[str], limit: int | None = None) -> int:
        """Aggregate every row waiting in ``ring`` (at most about ``limit``); return how
        many."""
        width = FIXED_COLUMNS + len(components)
        stride = ring.record_size // 8
        import numpy as np

        hists = [self.components.setdefault(n, self._new()) for n in components]
        if self._columns is None or not self._columns.covers(hists):
            from ._histogram import HistogramColumns

            self._columns = HistogramColumns(hists)
        columns = self._columns
        total = 0
        while limit is None or total < limit:
            start, n = ring.pending()
            if n == 0:
                break
            # a bounded batch: after a stall, a backlog of many thousand rows in one go
            # would leave the supervisor's heap that much larger for good
            n = min(n, CONSUME_BATCH)
            flat = np.frombuffer(
                ring.data, dtype=np.int64, count=n * stride, offset=start * ring.record_size
            )
            rows = flat.reshape(n, stride)[:, :width].copy()  # copy: let go of the ring at once
            del flat
            ring.release(n)
            self.jitter.add(rows[:, COL_JITTER])
            self.calc.add(rows[:, COL_CALC])
            phase = rows[:, COL_PHASE]
            if phase.max() == 0:  # one rate (or one phase in this batch): no mask
                self._phase(0).add(rows[:, COL_CALC])
            else:
                for p in np.unique(phase).tolist():
                    self._phase(p).add(rows[phase == p, COL_CALC])
            # each component's column (negative: an iteration it did not run in)
            columns.add(rows[:, FIXED_COLUMNS:width])
            self.overruns += int(rows[:, COL_OVERRAN].sum())
            self.last_iteration = int(rows[-1, COL_ITERATION])
            self.rows += n
            total += n
            if self.on_rows is not None:
                self.on_rows(rows)
        return total

    def _phase(self, p: int) -> LogHistogram:
        hist = self.phases.get(p)
        if hist is None:
            hist = self.phases[p] = self._new()
        return hist

    def finish(self, ring: Ring, components: Sequence[str]) -> None:
        """Drain ``ring`` a last time and account for the rows it had to drop."""
        self.consume(ring, components)
        self.dropped += ring.dropped

    def summary(self, iterations: int | None = None, overruns: int | None = None) -> TimingSummary:
        """The quantiles; ``iterations``/``overruns`` as counted by the loop, when known."""
        return TimingSummary(
            iterations=self.rows + self.dropped if iterations is None else iterations,
            samples=self.rows,
            overruns=self.overruns if overruns is None else overruns,
            jitter_us=self.jitter.summary_us(),
            calc_us=self.calc.summary_us(),
            components_us={n: h.summary_us() for n, h in self.components.items() if len(h)},
            phases_us=(
                {p: self.phases[p].summary_us() for p in sorted(self.phases)}
                if len(self.phases) > 1
                else {}
            ),
        )

    def histograms(self) -> dict[str, Any]:
        """The histograms as JSON-able dicts (for timing.json)."""
        return {
            "jitter": self.jitter.to_dict(),
            "calc": self.calc.to_dict(),
            "components": {n: h.to_dict() for n, h in self.components.items() if len(h)},
            **(
                {"phases": {str(p): self.phases[p].to_dict() for p in sorted(self.phases)}}
                if len(self.phases) > 1
                else {}
            ),
        }


class LoopSpan:
    """The loop as a whole when lanes run it side by side: per iteration, from the
    first lock-step lane's start to the last one's end (its calculation), and from
    the deadline to the first start (its wake-up jitter). Fed with every lock-step
    lane's timing rows, from the threads that drain them."""

    OPEN_MAX = 4096  # iterations some lane has not reported yet (its rows dropped)

    def __init__(self, lanes: int, period_ns: int) -> None:
        import threading

        from ._histogram import LogHistogram

        self.lanes = lanes
        self.period_ns = period_ns
        self.jitter = LogHistogram()
        self.calc = LogHistogram()
        self.rows = 0  # iterations every lane reported
        self.overruns = 0  # among them: the last lane ended past the next deadline
        self.incomplete = 0  # iterations given up on (a lane's row was dropped)
        self._open: dict[int, list[int]] = {}  # iteration -> [lanes, start, end, deadline]
        self._lock = threading.Lock()
        # called with the loop's rows as a lane's own come (the same columns: iteration,
        # deadline, jitter, calculation, overran): ~/iteration_info, a recording
        self.on_rows: Any = None

    def snapshot(self, like: TimingAggregate) -> TimingAggregate:
        """The loop so far as an aggregate (for /diagnostics and the status line):
        its calculation, jitter and overruns, ``like``'s components and dropped rows."""
        out = TimingAggregate()
        with self._lock:
            out.calc, out.jitter = self.calc.copy(), self.jitter.copy()
            out.rows, out.overruns = self.rows, self.overruns
        out.components = dict(like.components)
        out.dropped = like.dropped
        return out

    def add(self, rows: Any) -> None:
        """One lane's batch of timing rows (numpy int64, n x columns)."""
        starts = rows[:, COL_SCHEDULED] + rows[:, COL_JITTER]
        ends = starts + rows[:, COL_CALC]
        whole: list[tuple[int, int, int, int, int, int]] = []
        with self._lock:
            for i, start, end, deadline in zip(
                rows[:, COL_ITERATION].tolist(), starts.tolist(), ends.tolist(),
                rows[:, COL_SCHEDULED].tolist(), strict=True,
            ):
                entry = self._open.get(i)
                if entry is None:
                    entry = self._open[i] = [0, start, end, deadline]
                entry[0] += 1
                entry[1] = min(entry[1], start)
                entry[2] = max(entry[2], end)
                if entry[0] == self.lanes:
                    del self._open[i]
                    calc, jitter = entry[2] - entry[1], entry[1] - entry[3]
                    self.calc.add_one(calc)
                    self.jitter.add_one(jitter)
                    self.rows += 1
                    overran = int(entry[2] > entry[3] + self.period_ns)
                    self.overruns += overran
                    whole.append((i, entry[3], jitter, calc, overran, 0))
            if len(self._open) > self.OPEN_MAX:
                for i in sorted(self._open)[: self.OPEN_MAX // 2]:
                    del self._open[i]
                    self.incomplete += 1
            if whole and self.on_rows is not None:  # (in the lock: one caller at a time)
                import numpy as np

                self.on_rows(np.array(whole, dtype=np.int64))


@dataclass
class TimingSummary:
    iterations: int
    samples: int
    overruns: int
    jitter_us: dict[str, float] = field(default_factory=dict)
    calc_us: dict[str, float] = field(default_factory=dict)
    components_us: dict[str, dict[str, float]] = field(default_factory=dict)
    # several rates: the iteration's calculation time per phase of the hyperperiod
    phases_us: dict[int, dict[str, float]] = field(default_factory=dict)

    def coverage_note(self) -> str:
        if self.samples < self.iterations:
            lost = self.iterations - self.samples
            return (
                f"quantiles over {self.samples} of {self.iterations} iterations: {lost} rows "
                "found the timing ring full (the supervisor fell behind)"
            )
        return ""
