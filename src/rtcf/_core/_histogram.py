"""Log-linear histogram of nanosecond timing samples (HdrHistogram-like).

A loop at 2 kHz records two samples (wake-up jitter, calculation time) every
0.5 ms: an hour is 7.2 million of each, a day-long soak test 170 million. Keeping
them all to sort for quantiles costs memory that grows without bound; a
histogram with buckets of equal *relative* width keeps a small fixed array
(4352 int64 counters, 34 KiB) however long the run, merges across processes by
adding arrays, and still gives every quantile to within 1/128 (under 0.8 %).

Buckets: every value 0..255 ns has a bucket of its own (exact); above that each
power-of-two octave [2^e, 2^(e+1)) is split into 128 equal sub-buckets of width
2^(e-7), up to 2^40 ns (about 18 minutes). Negative values (a clock may report a
start before the deadline) are counted in bucket 0, values of 2^40 ns and more in
the last bucket; ``min``, ``max``, ``count`` and ``sum`` are kept exactly, so the
extremes and the mean are always exact.

Quantiles are nearest rank, as in :func:`rtcf._core._timing.quantile`: the bucket that
holds the ``ceil(q * count)``-th smallest sample is found, and its largest value
is returned (clamped to the exact min and max). The result is thus never below
the exact quantile and at most one bucket width above it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt

SUB_BITS = 7
SUB_BUCKETS = 1 << SUB_BITS  # sub-buckets per octave; relative width <= 1/128
MAX_BITS = 40  # values up to 2**40 ns (~18 min) are bucketed; larger ones clamp
LIMIT_NS = 1 << MAX_BITS
N_BUCKETS = (MAX_BITS - SUB_BITS + 1) * SUB_BUCKETS  # 34 * 128 = 4352

# Same keys and quantiles as rtcf._core._timing.summarize_ns.
SUMMARY_QUANTILES = (("p50", 0.5), ("p90", 0.9), ("p99", 0.99), ("p999", 0.999))

_INT64_MAX = int(np.iinfo(np.int64).max)


def _bucket_edges() -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Lower edges and (exclusive) upper edges of every bucket, in ns."""
    i = np.arange(N_BUCKETS, dtype=np.int64)
    shift = np.maximum(i // SUB_BUCKETS - 1, 0)
    lower = (i - shift * SUB_BUCKETS) << shift
    upper = lower + (np.int64(1) << shift)
    return lower, upper


LOWER_EDGES, UPPER_EDGES = _bucket_edges()
LOWER_EDGES.setflags(write=False)
UPPER_EDGES.setflags(write=False)


def bucket_index(value: int) -> int:
    """Index of the bucket that counts ``value`` (ns)."""
    v = min(max(int(value), 0), LIMIT_NS - 1)
    shift = max(v.bit_length() - SUB_BITS - 1, 0)
    return (shift << SUB_BITS) + (v >> shift)


def bucket_indices(values: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Vectorised :func:`bucket_index` of an int64 array."""
    v = np.clip(values, 0, LIMIT_NS - 1)
    # frexp gives v = m * 2**exp with 0.5 <= m < 1, so exp is v's bit length; exact
    # because every v < 2**40 is exactly representable as a float64.
    _, bit_length = np.frexp(v.astype(np.float64))
    shift = np.maximum(bit_length.astype(np.int64) - (SUB_BITS + 1), 0)
    return (shift << SUB_BITS) + (v >> shift)


def _as_int64(values: Iterable[int] | npt.ArrayLike) -> npt.NDArray[np.int64]:
    arr = np.asarray(values)
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    arr = arr.reshape(-1)
    if arr.dtype.kind == "u":
        if int(arr.max()) > _INT64_MAX:
            raise ValueError("timing samples must fit in int64 nanoseconds")
    elif arr.dtype.kind != "i":
        raise TypeError(f"timing samples must be integer nanoseconds, not {arr.dtype}")
    return arr.astype(np.int64, copy=False)


class LogHistogram:
    """Counts of int64 nanosecond samples in log-linear buckets, with exact extremes.

    ``count``, ``min``, ``max`` and ``sum`` are exact (``min``/``max`` are ``None``
    while empty); quantiles are within one bucket (< 0.8 %) above the exact ones.
    """

    __slots__ = ("count", "counts", "max", "min", "sum")

    def __init__(self) -> None:
        self.counts: npt.NDArray[np.int64] = np.zeros(N_BUCKETS, dtype=np.int64)
        self.count = 0
        self.min: int | None = None
        self.max: int | None = None
        self.sum = 0  # Python int: cannot overflow

    # -- recording ---------------------------------------------------------

    def add(self, values: Iterable[int] | npt.ArrayLike) -> None:
        """Count every value of a 1-D integer array (ns), without a loop per value."""
        arr = _as_int64(values)
        n = int(arr.size)
        if n == 0:
            return
        lo = int(arr.min())
        hi = int(arr.max())
        self.counts += np.bincount(bucket_indices(arr), minlength=N_BUCKETS)
        if max(abs(lo), abs(hi)) * n <= _INT64_MAX:
            self.sum += int(arr.sum(dtype=np.int64))
        else:  # an int64 sum could overflow: add as Python ints
            self.sum += sum(arr.tolist())
        self._extend(n, lo, hi)

    def add_one(self, value: int) -> None:
        """Count one value (ns)."""
        v = int(value)
        self.counts[bucket_index(v)] += 1
        self.sum += v
        self._extend(1, v, v)

    def _extend(self, n: int, lo: int, hi: int) -> None:
        self.count += n
        self.min = lo if self.min is None else min(self.min, lo)
        self.max = hi if self.max is None else max(self.max, hi)

    def merge(self, other: LogHistogram) -> None:
        """Add the samples of ``other`` to this histogram."""
        if other.count == 0:
            return
        assert other.min is not None and other.max is not None
        self.counts += other.counts
        self.sum += other.sum
        self._extend(other.count, other.min, other.max)

    def reset(self) -> None:
        """Forget every sample."""
        self.counts[:] = 0
        self.count = 0
        self.min = None
        self.max = None
        self.sum = 0

    def copy(self) -> LogHistogram:
        new = LogHistogram()
        new.merge(self)
        return new

    def __len__(self) -> int:
        return self.count

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, LogHistogram):
            return NotImplemented
        return (
            self.count == other.count
            and self.min == other.min
            and self.max == other.max
            and self.sum == other.sum
            and bool(np.array_equal(self.counts, other.counts))
        )

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __repr__(self) -> str:
        return f"LogHistogram(count={self.count}, min={self.min}, max={self.max})"

    # -- statistics --------------------------------------------------------

    @property
    def mean(self) -> float:
        """Exact mean in ns; NaN when empty."""
        return self.sum / self.count if self.count else math.nan

    def quantile(self, q: float) -> float:
        """Nearest-rank ``q`` quantile in ns (q in [0, 1]); NaN when empty.

        The largest value of the bucket that holds the ``ceil(q * count)``-th
        smallest sample, clamped to the exact min and max: never below the exact
        quantile, at most one bucket width (< 0.8 %) above it. q=0 gives the exact
        min, q=1 the exact max.
        """
        if not 0.0 <= q <= 1.0:
            raise ValueError(f"quantile must be in [0, 1], got {q}")
        if self.count == 0:
            return math.nan
        assert self.min is not None and self.max is not None
        if q == 0.0:
            return float(self.min)
        rank = min(max(1, math.ceil(q * self.count)), self.count)
        cumulative = np.cumsum(self.counts)
        i = int(np.searchsorted(cumulative, rank, side="left"))
        if i >= N_BUCKETS - 1:  # the last bucket also holds values beyond 2**40 ns
            return float(self.max)
        top = int(UPPER_EDGES[i]) - 1  # largest value the bucket holds
        return float(min(max(top, self.min), self.max))

    def summary_us(self) -> dict[str, float]:
        """min, p50, p90, p99, p99.9, max and mean in microseconds; {} when empty.

        The same keys as :func:`rtcf._core._timing.summarize_ns`.
        """
        if self.count == 0:
            return {}
        assert self.min is not None and self.max is not None
        out = {"min": self.min / 1e3}
        for key, q in SUMMARY_QUANTILES:
            out[key] = self.quantile(q) / 1e3
        out["max"] = self.max / 1e3
        out["mean"] = self.sum / self.count / 1e3
        return out

    def nonzero(
        self,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """Lower edges, exclusive upper edges (ns) and counts of the non-empty buckets.

        Bucket 0 also holds negative values and the last bucket values of 2**40 ns
        and more: compare with ``min``/``max``.
        """
        idx = np.flatnonzero(self.counts)
        return LOWER_EDGES[idx].copy(), UPPER_EDGES[idx].copy(), self.counts[idx].copy()

    # -- JSON --------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dict; only the non-empty buckets, as [lower_edge_ns, count]."""
        lower, _, counts = self.nonzero()
        return {
            "unit": "ns",
            "sub_buckets": SUB_BUCKETS,
            "count": self.count,
            "min": self.min,
            "max": self.max,
            "sum": self.sum,
            "buckets": [[e, c] for e, c in zip(lower.tolist(), counts.tolist(), strict=True)],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LogHistogram:
        """The histogram that :meth:`to_dict` gave; ValueError if it does not fit."""
        if data.get("unit") != "ns" or data.get("sub_buckets") != SUB_BUCKETS:
            raise ValueError(
                f"histogram must have unit 'ns' and {SUB_BUCKETS} sub-buckets, got "
                f"unit {data.get('unit')!r} and {data.get('sub_buckets')!r} sub-buckets"
            )
        h = cls()
        for edge, n in data.get("buckets", []):
            i = bucket_index(int(edge))
            if int(LOWER_EDGES[i]) != int(edge) or int(n) < 0:
                raise ValueError(f"histogram bucket [{edge}, {n}] is not a bucket edge and count")
            h.counts[i] += int(n)
        h.count = int(data["count"])
        h.sum = int(data["sum"])
        if h.count:
            h.min = int(data["min"])
            h.max = int(data["max"])
        if int(h.counts.sum()) != h.count:
            raise ValueError(
                f"histogram count {h.count} differs from its buckets' sum {int(h.counts.sum())}"
            )
        return h


class HistogramColumns:
    """The histograms of many columns (one per component), counted together: their
    counters are rows of one block, so a batch of rows is counted in a few numpy calls
    whatever the number of columns (one ``add`` per column per batch cost the
    supervisor 30 µs a column: with a hundred components at 1 kHz it fell behind its
    timing rows). Negative values (the component did not run) are not counted."""

    __slots__ = ("block", "hists")

    def __init__(self, hists: list[LogHistogram]) -> None:
        self.hists = hists
        self.block: npt.NDArray[np.int64] = np.zeros((len(hists), N_BUCKETS), dtype=np.int64)
        for k, hist in enumerate(hists):  # the histograms count into the block from now on
            self.block[k] = hist.counts
            hist.counts = self.block[k]

    def covers(self, hists: list[LogHistogram]) -> bool:
        return len(hists) == len(self.hists) and all(
            a is b for a, b in zip(hists, self.hists, strict=True))

    def add(self, values: npt.NDArray[np.int64]) -> None:
        """Count an (n, columns) int64 array, column k into histogram k."""
        n, k = values.shape
        if n == 0 or k == 0:
            return
        valid = values >= 0
        counted = valid.sum(axis=0)
        idx = bucket_indices(values) + (np.arange(k, dtype=np.int64) * N_BUCKETS)
        flat = self.block.reshape(-1)
        if valid.all():
            chosen = idx.reshape(-1)
        else:
            chosen = idx[valid]
        if chosen.size * 8 < flat.size:  # a small batch: count in place
            np.add.at(flat, chosen, 1)
        else:
            flat += np.bincount(chosen, minlength=flat.size)
        lo = np.where(valid, values, _INT64_MAX).min(axis=0).tolist()
        hi = np.where(valid, values, -1).max(axis=0).tolist()
        sums = np.where(valid, values, 0).sum(axis=0, dtype=np.int64).tolist()
        for j, c in enumerate(counted.tolist()):
            if c:
                hist = self.hists[j]
                hist.sum += sums[j]
                hist._extend(c, lo[j], hi[j])
