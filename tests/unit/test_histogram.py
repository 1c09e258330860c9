"""Log-linear histogram of nanosecond samples: buckets, quantiles, merge, JSON."""

from __future__ import annotations

import json
import math

import numpy as np
import numpy.typing as npt
import pytest

from rtcf._core._histogram import (
    LIMIT_NS,
    LOWER_EDGES,
    N_BUCKETS,
    UPPER_EDGES,
    LogHistogram,
    bucket_index,
    bucket_indices,
)

QUANTILES = (0.5, 0.9, 0.99, 0.999)


def lognormal_ns(n: int = 200_000, seed: int = 1) -> npt.NDArray[np.int64]:
    """Calculation-time-like samples: median ~3 µs, a tail into the milliseconds."""
    rng = np.random.default_rng(seed)
    bulk = rng.lognormal(mean=math.log(3_000), sigma=0.6, size=n)
    tail = rng.choice(n, size=n // 500, replace=False)
    bulk[tail] = rng.uniform(20_000, 3_000_000, size=tail.size)
    return bulk.astype(np.int64)


@pytest.fixture(scope="module")
def data() -> npt.NDArray[np.int64]:
    return lognormal_ns()


def hist_of(values: npt.ArrayLike) -> LogHistogram:
    h = LogHistogram()
    h.add(values)
    return h


def test_buckets_tile_the_range_with_relative_width_below_1_128() -> None:
    assert N_BUCKETS == 34 * 128
    assert LOWER_EDGES[0] == 0 and UPPER_EDGES[-1] == LIMIT_NS == 2**40
    assert np.array_equal(LOWER_EDGES[1:], UPPER_EDGES[:-1])
    width = UPPER_EDGES - LOWER_EDGES
    assert np.all(width[:256] == 1)  # exact below 256 ns
    assert np.all(width[128:] * 128 <= LOWER_EDGES[128:])


def test_vectorised_bucketing_matches_scalar() -> None:
    rng = np.random.default_rng(7)
    values = np.concatenate(
        [
            np.arange(-3, 1100, dtype=np.int64),
            2 ** np.arange(0, 45, dtype=np.int64),
            2 ** np.arange(1, 45, dtype=np.int64) - 1,
            rng.integers(0, 2**41, 5_000, dtype=np.int64),
        ]
    )
    expected = np.array([bucket_index(int(v)) for v in values])
    assert np.array_equal(bucket_indices(values), expected)
    inside = (values >= 0) & (values < LIMIT_NS)
    idx = expected[inside]
    assert np.all(LOWER_EDGES[idx] <= values[inside])
    assert np.all(values[inside] < UPPER_EDGES[idx])


def test_quantiles_within_one_bucket_above_exact(data: npt.NDArray[np.int64]) -> None:
    h = hist_of(data)
    for q in QUANTILES:
        exact = float(np.quantile(data, q, method="inverted_cdf"))
        approx = h.quantile(q)
        assert approx >= exact, q
        assert (approx - exact) / exact <= 1 / 128, q


def test_exact_count_min_max_mean(data: npt.NDArray[np.int64]) -> None:
    h = hist_of(data)
    assert h.count == len(h) == data.size
    assert h.min == int(data.min()) and h.max == int(data.max())
    assert h.sum == sum(data.tolist())
    assert h.mean == pytest.approx(float(data.mean()), rel=1e-12)
    assert h.quantile(0.0) == float(data.min())
    assert h.quantile(1.0) == float(data.max())


def test_small_values_are_exact() -> None:
    values = np.array([5, 0, 127, 64, 64, 3, 100, 127, 9, 1], dtype=np.int64)
    h = hist_of(values)
    for q in (0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 1.0):
        assert h.quantile(q) == float(np.quantile(values, q, method="inverted_cdf")), q
    lower, upper, counts = h.nonzero()
    assert lower.tolist() == [0, 1, 3, 5, 9, 64, 100, 127]
    assert (upper - lower).tolist() == [1] * 8
    assert counts.tolist() == [1, 1, 1, 1, 1, 2, 1, 2]


def test_negative_values_count_in_bucket_zero_and_keep_exact_min() -> None:
    h = hist_of(np.array([-250, -3, 10, 20], dtype=np.int64))
    assert h.counts[0] == 2
    assert h.min == -250 and h.max == 20 and h.sum == -223
    assert h.quantile(0.0) == -250.0
    assert h.quantile(0.5) == 0.0  # bucket 0's top: above the exact -3, as promised
    assert h.quantile(0.75) == 10.0
    only_negative = hist_of([-7, -5])
    assert only_negative.quantile(0.5) == -5.0  # never above the exact max
    assert only_negative.summary_us()["max"] == -0.005


def test_values_beyond_2_40_go_to_the_last_bucket() -> None:
    huge = [LIMIT_NS, 3 * LIMIT_NS, 2**62]
    h = hist_of(np.array([1_000, *huge], dtype=np.int64))
    assert h.counts[-1] == 3 and h.count == 4
    assert h.max == 2**62
    assert h.sum == 1_000 + sum(huge)  # a Python int: no overflow
    assert h.quantile(0.25) == 1_003.0  # top of the bucket [1000, 1004)
    # The last bucket is open-ended: it answers the exact max, never below the truth.
    assert h.quantile(0.5) == float(2**62)
    assert h.quantile(1.0) == float(2**62)
    one = LogHistogram()
    for v in [1_000, *huge]:
        one.add_one(v)
    assert one == h


def test_add_and_add_one_agree(data: npt.NDArray[np.int64]) -> None:
    part = data[:3_000]
    one = LogHistogram()
    for v in part.tolist():
        one.add_one(v)
    assert one == hist_of(part)
    assert one == hist_of(part.tolist())  # any 1-D array-like of ints
    assert np.array_equal(one.counts, hist_of(part).counts)


def test_add_rejects_floats_and_accepts_empty() -> None:
    h = LogHistogram()
    h.add([])
    h.add(np.zeros(0, dtype=np.int64))
    assert h.count == 0 and h.min is None
    with pytest.raises(TypeError):
        h.add(np.array([1.5]))
    h.add(np.array([3, 4], dtype=np.uint32))
    assert h.count == 2 and h.sum == 7


def test_merge_equals_adding_both(data: npt.NDArray[np.int64]) -> None:
    a, b = data[:70_000], data[70_000:]
    merged = hist_of(a)
    merged.merge(hist_of(b))
    assert merged == hist_of(data)
    merged.merge(LogHistogram())
    assert merged == hist_of(data)
    empty = LogHistogram()
    empty.merge(hist_of(b))
    assert empty == hist_of(b)


def test_copy_and_reset(data: npt.NDArray[np.int64]) -> None:
    h = hist_of(data[:1000])
    c = h.copy()
    assert c == h and c is not h
    h.add_one(5)
    assert c != h and c.count == 1000
    h.reset()
    assert h == LogHistogram()
    assert h.count == 0 and h.min is None and h.max is None and h.sum == 0


def test_to_dict_round_trips_through_json(data: npt.NDArray[np.int64]) -> None:
    h = hist_of(np.concatenate([data, np.array([-4, 2**41], dtype=np.int64)]))
    d = h.to_dict()
    assert d["unit"] == "ns" and d["sub_buckets"] == 128
    assert d["count"] == h.count and d["min"] == -4 and d["max"] == 2**41
    assert all(n > 0 for _, n in d["buckets"])
    back = LogHistogram.from_dict(json.loads(json.dumps(d)))
    assert back == h
    assert back.summary_us() == h.summary_us()
    empty = LogHistogram.from_dict(json.loads(json.dumps(LogHistogram().to_dict())))
    assert empty == LogHistogram()


@pytest.mark.parametrize(
    "change",
    [{"unit": "us"}, {"sub_buckets": 64}, {"count": 4}, {"buckets": [[129, 2], [1001, 1]]}],
)
def test_from_dict_rejects_what_does_not_fit(change: dict[str, object]) -> None:
    d = hist_of([129, 129, 1000]).to_dict()
    d.update(change)
    with pytest.raises(ValueError):
        LogHistogram.from_dict(d)


def test_empty_histogram() -> None:
    h = LogHistogram()
    assert len(h) == 0
    assert math.isnan(h.quantile(0.5)) and math.isnan(h.quantile(0.0))
    assert math.isnan(h.mean)
    assert h.summary_us() == {}
    lower, upper, counts = h.nonzero()
    assert lower.size == upper.size == counts.size == 0
    with pytest.raises(ValueError):
        h.quantile(1.5)


def test_summary_us_keys_and_values(data: npt.NDArray[np.int64]) -> None:
    s = hist_of(data).summary_us()
    assert list(s) == ["min", "p50", "p90", "p99", "p999", "max", "mean"]
    assert s["min"] == data.min() / 1e3 and s["max"] == data.max() / 1e3
    assert s["mean"] == pytest.approx(data.mean() / 1e3)
    assert 2.9 < s["p50"] < 3.1
    assert s["min"] <= s["p50"] <= s["p90"] <= s["p99"] <= s["p999"] <= s["max"]


@pytest.mark.parametrize("rows", [3, 5000])  # counted in place, and by one bincount
def test_columns_counted_as_one_block_equal_one_histogram_per_column(rows):
    from rtcf._core._histogram import HistogramColumns

    rng = np.random.default_rng(7)
    values = rng.integers(0, 3_000_000, size=(rows, 4), dtype=np.int64)
    values[::3, 1] = -1  # a component that did not run in every third iteration
    values[:, 3] = -1  # one that never ran
    alone = [LogHistogram() for _ in range(4)]
    for k, hist in enumerate(alone):
        col = values[:, k]
        hist.add(col[col >= 0])
    together = [LogHistogram() for _ in range(4)]
    together[0].add([5, 6])  # counted before the block took the counters over
    alone[0].add([5, 6])
    columns = HistogramColumns(together)
    columns.add(values[: rows // 2])
    columns.add(values[rows // 2 :])
    for a, b in zip(alone, together, strict=True):
        assert (a.count, a.min, a.max, a.sum) == (b.count, b.min, b.max, b.sum)
        assert np.array_equal(a.counts, b.counts)
    assert together[3].count == 0 and together[3].min is None
    assert columns.covers(together) and not columns.covers(together[:3])


def test_a_bounded_consume_leaves_the_rest_for_the_next():
    from rtcf._core._timing import CONSUME_BATCH, TimingAggregate, local_ring

    ring = local_ring(2, capacity=4 * CONSUME_BATCH)
    words = ring.data.cast("q")
    stride = ring.record_size // 8
    for _ in range(3 * CONSUME_BATCH):
        off = ring.reserve()
        for w in range(stride):
            words[(off >> 3) + w] = 1000
        ring.commit()
    words.release()
    agg = TimingAggregate()
    assert agg.consume(ring, ["/a", "/b"], CONSUME_BATCH) == CONSUME_BATCH
    assert agg.consume(ring, ["/a", "/b"]) == 2 * CONSUME_BATCH
    assert agg.components["/a"].count == 3 * CONSUME_BATCH
