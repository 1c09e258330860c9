"""Quantiles and timing summaries."""

from __future__ import annotations

import math
import random
import struct
from array import array

import numpy as np
import pytest

from rtcf._core._rings import Ring
from rtcf._core._timing import (
    COL_CALC,
    COL_ITERATION,
    COL_JITTER,
    COL_SCHEDULED,
    FIXED_COLUMNS,
    ITERATION_INFO_BYTES,
    TimingAggregate,
    iteration_info_doubles,
    local_ring,
    quantile,
    ring_capacity,
    row_size,
    summarize_ns,
)


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


def _push_rows(ring: Ring, rows: list[list[int]]) -> None:
    for row in rows:
        record = array("q", row + [0] * (ring.record_size // 8 - len(row)))
        assert ring.push(record.tobytes())


def _row(
    i: int, jitter: int, calc: int, per: list[int], overran: int = 0, phase: int = 0
) -> list[int]:
    return [i, i * 1000, jitter, calc, overran, phase, *per]


def test_row_size_and_capacity_budget() -> None:
    assert row_size(0) == 8 * FIXED_COLUMNS
    assert row_size(5) == 88
    assert ring_capacity(5) == 1 << 16  # 16 MiB is far more than 2^16 rows of 88 bytes
    assert ring_capacity(1000) == 2048
    assert ring_capacity(10**6) == 256  # never fewer than 256 rows


def test_aggregate_counts_quantiles_and_components() -> None:
    ring = local_ring(2, 8)
    _push_rows(
        ring,
        [_row(i, 1000 * (i + 1), 2000 * (i + 1), [500, 1500 * (i + 1)], i % 2) for i in range(4)],
    )
    agg = TimingAggregate()
    assert agg.consume(ring, ["/a", "/b"]) == 4
    assert len(ring) == 0
    assert agg.rows == 4 and agg.overruns == 2 and agg.last_iteration == 3
    s = agg.summary()
    assert s.iterations == 4 and s.samples == 4 and s.overruns == 2
    assert s.jitter_us["min"] == 1.0 and s.jitter_us["max"] == 4.0
    assert s.calc_us["p50"] == pytest.approx(4.0, rel=1 / 128)
    assert s.components_us["/a"]["max"] == 0.5
    assert s.components_us["/b"]["max"] == 6.0
    assert s.coverage_note() == ""
    assert s.phases_us == {}  # one rate: no table per phase
    assert "phases" not in agg.histograms()


def test_aggregate_per_phase_and_per_component_only_where_it_ran() -> None:
    # hyperperiod 3: /slow runs in phase 1 only (-1 elsewhere), and costs 9 us there
    ring = local_ring(2, 16)
    rows = [
        _row(i, 0, 2000 + (9000 if i % 3 == 1 else 0), [2000, 9000 if i % 3 == 1 else -1], 0, i % 3)
        for i in range(9)
    ]
    _push_rows(ring, rows[:4])
    agg = TimingAggregate()
    agg.consume(ring, ["/fast", "/slow"])
    _push_rows(ring, rows[4:])  # a second batch: histograms per phase keep adding up
    agg.consume(ring, ["/fast", "/slow"])
    s = agg.summary()
    assert sorted(s.phases_us) == [0, 1, 2]
    assert s.phases_us[1]["min"] == s.phases_us[1]["max"] == 11.0
    assert s.phases_us[0]["max"] == s.phases_us[2]["max"] == 2.0
    assert [agg.phases[p].count for p in range(3)] == [3, 3, 3]
    assert agg.components["/slow"].count == 3  # only the iterations it ran in
    assert s.components_us["/slow"]["min"] == 9.0
    assert agg.components["/fast"].count == 9
    assert sorted(agg.histograms()["phases"]) == ["0", "1", "2"]


def test_aggregate_drains_across_the_wrap_and_counts_drops() -> None:
    ring = local_ring(1, 4)
    agg = TimingAggregate()
    _push_rows(ring, [_row(i, 10, 20, [20]) for i in range(3)])
    agg.consume(ring, ["/a"])
    _push_rows(ring, [_row(i, 10, 20, [20]) for i in range(3, 7)])  # wraps around
    assert not ring.push(bytearray(ring.record_size))  # full: dropped and counted
    agg.finish(ring, ["/a"])
    assert agg.rows == 7 and agg.last_iteration == 6
    assert agg.dropped == 1
    s = agg.summary()
    assert s.iterations == 8 and s.samples == 7
    assert "7 of 8 iterations" in s.coverage_note()


def test_aggregate_summary_takes_the_loops_own_counts() -> None:
    agg = TimingAggregate()
    s = agg.summary(iterations=5, overruns=1)
    assert (s.iterations, s.samples, s.overruns) == (5, 0, 1)
    assert s.jitter_us == {} and s.components_us == {}


def test_histograms_are_json_ready() -> None:
    import json

    ring = local_ring(1, 4)
    _push_rows(ring, [_row(0, 10, 20, [20])])
    agg = TimingAggregate()
    agg.consume(ring, ["/a"])
    doc = json.loads(json.dumps(agg.histograms()))
    assert doc["calc"]["count"] == 1 and set(doc["components"]) == {"/a"}


def test_aggregate_takes_a_backlog_in_bounded_batches() -> None:
    from rtcf._core._timing import CONSUME_BATCH

    # after a stall the ring holds thousands of rows: they reach on_rows (iteration_info,
    # the recording) in batches of at most CONSUME_BATCH, in order, every one of them
    n = 2 * CONSUME_BATCH + 100
    ring = local_ring(1, 4 * CONSUME_BATCH)
    _push_rows(ring, [_row(i, 1000, 2000, [500], 0) for i in range(n)])
    agg = TimingAggregate()
    batches: list[list[int]] = []
    agg.on_rows = lambda rows: batches.append(rows[:, 0].tolist())
    assert agg.consume(ring, ["/a"]) == n
    assert max(len(b) for b in batches) == CONSUME_BATCH
    assert [i for b in batches for i in b] == list(range(n))
    assert agg.rows == n and len(ring) == 0


def test_iteration_info_doubles_are_what_float_arithmetic_on_each_row_gives() -> None:
    rnd = random.Random(7)
    offset = 1_763_900_000_123_456_789 - 31_415_926_535_897  # wall minus monotonic, ns
    rows = np.zeros((300, FIXED_COLUMNS + 2), dtype=np.int64)
    for k, row in enumerate(rows):
        row[COL_ITERATION] = 10_000_000 + k
        row[COL_SCHEDULED] = 31_415_926_535_897 + 500_000 * k
        row[COL_JITTER] = rnd.randint(-2_000, 70_000_000)  # a clock may report early
        row[COL_CALC] = rnd.randint(0, 5_000_000)
    data = iteration_info_doubles(rows, offset)
    assert len(data) == ITERATION_INFO_BYTES * len(rows)
    expected = b"".join(
        struct.pack(
            "<4d",
            float(it),
            (scheduled + offset) * 1e-9,
            calc * 1e-9,
            jitter * 1e-9,
        )
        for it, scheduled, calc, jitter in rows[
            :, [COL_ITERATION, COL_SCHEDULED, COL_CALC, COL_JITTER]
        ].tolist()
    )
    assert data == expected  # to the bit
    assert iteration_info_doubles(rows[:0], offset) == b""


def test_a_loop_span_joins_the_lanes_rows_by_iteration() -> None:
    import numpy as np

    from rtcf._core._timing import COL_CALC, COL_ITERATION, COL_JITTER, COL_SCHEDULED, LoopSpan

    def rows(*entries: tuple[int, int, int, int]) -> np.ndarray:
        out = np.zeros((len(entries), 6), dtype=np.int64)
        for k, (i, deadline, jitter, calc) in enumerate(entries):
            out[k, [COL_ITERATION, COL_SCHEDULED, COL_JITTER, COL_CALC]] = i, deadline, jitter, calc
        return out

    span = LoopSpan(2, 1_000_000)
    joined: list[list[list[int]]] = []
    span.on_rows = lambda rows: joined.append(rows.tolist())  # ~/iteration_info's rows
    # iteration 0: main starts 10 µs late and takes 100; the other starts 30 late, 200
    span.add(rows((0, 0, 10_000, 100_000), (1, 1_000_000, 5_000, 100_000)))
    assert span.rows == 0  # nothing is whole before every lane said its part
    span.add(rows((0, 0, 30_000, 200_000), (1, 1_000_000, 20_000, 990_000)))
    assert span.rows == 2
    assert span.jitter.min == 5_000 and span.jitter.max == 10_000  # the first start
    assert span.calc.min == 220_000  # from 10 µs to 230 µs
    assert span.calc.max == 1_005_000  # 1005 to 2010 µs: past the next deadline
    assert span.overruns == 1
    assert joined == [[[0, 0, 10_000, 220_000, 0, 0], [1, 1_000_000, 5_000, 1_005_000, 1, 0]]]
    # what the status line and /diagnostics show while it runs
    main = TimingAggregate()
    main.dropped = 3
    live = span.snapshot(main)
    assert (live.rows, live.overruns, live.dropped, live.calc.max) == (2, 1, 3, 1_005_000)
    assert live.summary().calc_us["max"] == pytest.approx(1005.0, rel=0.01)
    # a lane whose row was dropped: the iteration is given up on, not kept for ever
    span.add(rows(*[(i, i * 1_000_000, 0, 1) for i in range(2, 2 + LoopSpan.OPEN_MAX + 1)]))
    assert span.incomplete == LoopSpan.OPEN_MAX // 2
    assert span.rows == 2
