"""Timing samples of the loop and their summary (quantiles, overruns).

The loop writes every iteration's wake-up jitter and calculation time (whole and
per component) into arrays allocated before it starts. The arrays keep the last
``capacity`` iterations (a power of two); min, max and count cover all of them.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence
from dataclasses import dataclass, field

QUANTILES = (("p50", 0.5), ("p90", 0.9), ("p99", 0.99), ("p999", 0.999))


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


class TimingRecorder:
    """Preallocated per-iteration samples, written by the loop without allocation."""

    def __init__(self, components: Sequence[str], capacity: int = 1 << 18) -> None:
        size = 1
        while size < max(1, capacity):
            size <<= 1
        self.components = list(components)
        self.mask = size - 1
        self.jitter = array("q", bytes(8 * size))
        self.calc = array("q", bytes(8 * size))
        self.per_component = array("q", bytes(8 * size * max(1, len(self.components))))
        self.count = 0  # iterations recorded in total
        self.overruns = 0

    @property
    def capacity(self) -> int:
        return self.mask + 1

    def _kept(self) -> list[int]:
        """Ring indices of the samples still held, oldest first."""
        n = min(self.count, self.capacity)
        first = self.count - n
        return [(first + i) & self.mask for i in range(n)]

    def summary(self) -> TimingSummary:
        idx = self._kept()
        ncomp = len(self.components)
        per = {
            name: summarize_ns([self.per_component[i * ncomp + k] for i in idx])
            for k, name in enumerate(self.components)
        }
        return TimingSummary(
            iterations=self.count,
            samples=len(idx),
            overruns=self.overruns,
            jitter_us=summarize_ns([self.jitter[i] for i in idx]),
            calc_us=summarize_ns([self.calc[i] for i in idx]),
            components_us=per,
        )

    def samples_us(self) -> tuple[list[float], list[float]]:
        """The kept jitter and calculation samples in microseconds (for plots)."""
        idx = self._kept()
        return [self.jitter[i] / 1e3 for i in idx], [self.calc[i] / 1e3 for i in idx]


@dataclass
class TimingSummary:
    iterations: int
    samples: int
    overruns: int
    jitter_us: dict[str, float] = field(default_factory=dict)
    calc_us: dict[str, float] = field(default_factory=dict)
    components_us: dict[str, dict[str, float]] = field(default_factory=dict)

    def coverage_note(self) -> str:
        if self.samples < self.iterations:
            return f"quantiles over the last {self.samples} of {self.iterations} iterations"
        return ""
