"""Quantiles and timing summaries."""

from __future__ import annotations

import math

import pytest

from rtcf._timing import TimingRecorder, TimingSummary, quantile, summarize_ns


def test_quantile_of_nothing_is_nan() -> None:
    assert math.isnan(quantile([], 0.5))


@pytest.mark.parametrize(
    ("q", "expected"),
    [(0.0, 1), (0.1, 1), (0.11, 2), (0.5, 5), (0.55, 6), (0.9, 9), (0.91, 10), (0.99, 10),
     (1.0, 10)],
)
def test_quantile_is_nearest_rank(q: float, expected: int) -> None:
    values = list(range(1, 11))
    assert quantile(values, q) == float(expected)


def test_quantile_small_sets() -> None:
    assert quantile([7], 0.999) == 7.0
    assert quantile([1, 100], 0.5) == 1.0  # nearest rank, not interpolation
    assert quantile([1, 100], 0.51) == 100.0
    assert quantile([1.5, 2.5, 3.5, 4.5], 0.75) == 3.5


def test_p999_needs_a_thousand_samples_to_differ_from_max() -> None:
    values = list(range(1, 2001))
    assert quantile(values, 0.999) == 1998.0
    assert quantile(values, 0.99) == 1980.0


def test_summarize_ns_in_microseconds() -> None:
    s = summarize_ns([4000, 1000, 3000, 2000])
    assert s == {
        "min": 1.0,
        "p50": 2.0,
        "p90": 4.0,
        "p99": 4.0,
        "p999": 4.0,
        "max": 4.0,
        "mean": 2.5,
    }
    assert list(s) == ["min", "p50", "p90", "p99", "p999", "max", "mean"]
    assert summarize_ns([]) == {}


def _fill(rec: TimingRecorder, jitter: list[int], calc: list[int]) -> None:
    for j, c in zip(jitter, calc, strict=True):
        slot = rec.count & rec.mask
        rec.jitter[slot] = j
        rec.calc[slot] = c
        for k in range(len(rec.components)):
            rec.per_component[slot * len(rec.components) + k] = c * (k + 1)
        rec.count += 1


def test_recorder_capacity_rounds_up() -> None:
    assert TimingRecorder([], 5).capacity == 8
    assert TimingRecorder([], 8).capacity == 8
    assert TimingRecorder([], 0).capacity == 1
    assert len(TimingRecorder(["a", "b"], 4).per_component) == 8
    assert len(TimingRecorder([], 4).per_component) == 4


def test_summary_of_all_samples() -> None:
    rec = TimingRecorder(["/a", "/b"], 8)
    _fill(rec, [1000, 3000, 2000], [10_000, 30_000, 20_000])
    rec.overruns = 1
    s = rec.summary()
    assert (s.iterations, s.samples, s.overruns) == (3, 3, 1)
    assert s.jitter_us["min"] == 1.0 and s.jitter_us["max"] == 3.0
    assert s.jitter_us["p50"] == 2.0
    assert s.calc_us["mean"] == 20.0
    assert s.components_us["/a"]["max"] == 30.0
    assert s.components_us["/b"]["max"] == 60.0
    assert s.coverage_note() == ""


def test_ring_keeps_the_last_capacity_samples() -> None:
    rec = TimingRecorder(["/a"], 4)
    _fill(rec, list(range(1000, 11000, 1000)), list(range(1, 11)))  # 10 samples
    s = rec.summary()
    assert (s.iterations, s.samples) == (10, 4)
    assert s.jitter_us["min"] == 7.0  # samples 7..10 thousand ns remain
    assert s.jitter_us["max"] == 10.0
    jitter, calc = rec.samples_us()
    assert jitter == [7.0, 8.0, 9.0, 10.0]  # oldest first
    assert calc == [0.007, 0.008, 0.009, 0.01]
    assert s.coverage_note() == "quantiles over the last 4 of 10 iterations"


def test_empty_recorder_summary() -> None:
    s = TimingRecorder(["/a"], 4).summary()
    assert s == TimingSummary(0, 0, 0, {}, {}, {"/a": {}})
    assert TimingRecorder([], 4).samples_us() == ([], [])
