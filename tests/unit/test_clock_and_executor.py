"""Clocks and the loop executor, timed exactly on a SimClock."""

from __future__ import annotations

import weakref
from collections.abc import Callable

import pytest

from rtcf import MonotonicClock, SimClock
from rtcf._core._executor import Executor, StopFlag, UpdateFailure
from rtcf._core._loop_state import LoopState
from rtcf._core._timing import (
    COL_CALC,
    COL_ITERATION,
    COL_JITTER,
    COL_OVERRAN,
    COL_SCHEDULED,
    FIXED_COLUMNS,
    TimingWriter,
    local_ring,
)

P = 1_000_000  # period at 1 kHz


def _costs(table: dict[int, int]) -> Callable[[int], int]:
    """cost_ns by read index: read 0 is the loop's first now(); then, per iteration
    with one update, read 1+2k is the wake-up time and 2+2k the end of the update."""
    return lambda n: table.get(n, 0)


class Probe:
    """An update that records the loop state it sees."""

    def __init__(self, state: LoopState) -> None:
        self.state = state
        self.seen: list[tuple[int, int, bool]] = []

    def __call__(self) -> None:
        s = self.state
        self.seen.append((s.iteration, s.time_ns, s.running))


def _executor(
    clock: SimClock, updates: int = 1, policy: str = "absolute", capacity: int = 64
) -> tuple[Executor, list[Probe]]:
    state = LoopState(1000.0)
    probes = [Probe(state) for _ in range(updates)]
    timing = TimingWriter([f"/c{i}" for i in range(updates)], local_ring(updates, capacity))
    return Executor(probes, clock, state, timing, wait_policy=policy), probes


def _writer(ex: Executor) -> TimingWriter:
    assert ex.timing is not None
    return ex.timing


# by the writer itself, not id(): a later test's writer may get a freed one's id
_SEEN: weakref.WeakKeyDictionary[TimingWriter, list[list[int]]] = weakref.WeakKeyDictionary()


def _rows(ex: Executor) -> list[list[int]]:
    """Every row the executor committed so far (drained from its ring and kept)."""
    timing = _writer(ex)
    kept = _SEEN.setdefault(timing, [])
    ring = timing.ring
    while (row := ring.pop()) is not None:
        words = memoryview(row).cast("q")
        kept.append(list(words[: timing.width]))
        words.release()
    return kept


def _jitter_calc(ex: Executor) -> tuple[list[int], list[int]]:
    rows = _rows(ex)
    return [r[COL_JITTER] for r in rows], [r[COL_CALC] for r in rows]


def _per_component(ex: Executor) -> list[int]:
    return [t for r in _rows(ex) for t in r[FIXED_COLUMNS:]]


# -- SimClock --------------------------------------------------------------------
def test_simclock_moves_only_when_told() -> None:
    c = SimClock(5)
    assert c.simulated is True
    assert c.now_ns() == 5
    assert c.now_ns() == 5
    c.sleep_until_ns(100)
    assert c.now_ns() == 100
    c.sleep_until_ns(50)  # a deadline in the past does not move time back
    assert c.now_ns() == 100
    c.advance(7)
    assert c.now_ns() == 107


def test_simclock_latency_and_cost_get_call_counts() -> None:
    sleeps: list[int] = []
    reads: list[int] = []

    def latency(n: int) -> int:
        sleeps.append(n)
        return 10

    def cost(n: int) -> int:
        reads.append(n)
        return 1

    c = SimClock(wake_latency_ns=latency, cost_ns=cost)
    assert c.now_ns() == 1
    assert c.now_ns() == 2
    c.sleep_until_ns(100)
    assert c.now_ns() == 111
    c.sleep_until_ns(0)  # already past: only the latency
    assert c.now_ns() == 122
    assert sleeps == [0, 1]
    assert reads == [0, 1, 2, 3]


def test_monotonic_clock_is_not_simulated_and_past_deadline_returns() -> None:
    c = MonotonicClock()
    assert c.simulated is False
    a = c.now_ns()
    c.sleep_until_ns(a - 1_000_000_000)  # long past: must not block
    assert c.now_ns() >= a


# -- executor timing -----------------------------------------------------------------
def test_jitter_and_calc_are_exactly_the_simulated_values() -> None:
    clock = SimClock(
        wake_latency_ns=[1000, 2000, 3000].__getitem__,
        cost_ns=_costs({2: 10_000, 4: 20_000, 6: 30_000}),
    )
    ex, (probe,) = _executor(clock)
    assert ex.run(3, StopFlag()) == 3
    jitter, calc = _jitter_calc(ex)
    assert jitter == [1000, 2000, 3000]
    assert calc == [10_000, 20_000, 30_000]
    assert _per_component(ex) == [10_000, 20_000, 30_000]
    assert _writer(ex).overruns == 0
    rows = _rows(ex)
    assert [r[COL_ITERATION] for r in rows] == [0, 1, 2]
    # the scheduled start on the loop's clock (a SimClock starts at 0)
    assert [r[COL_SCHEDULED] - ex.origin_ns for r in rows] == [0, P, 2 * P]
    assert ex.origin_ns == 0
    assert [r[COL_OVERRAN] for r in rows] == [0, 0, 0]
    assert probe.seen == [(0, 0, True), (1, P, True), (2, 2 * P, True)]
    assert ex.state.running is False
    assert ex.state.iteration == 2


def test_per_component_times_are_split() -> None:
    # reads: 0 start; per iteration: t0, after update 0, after update 1
    clock = SimClock(cost_ns=_costs({2: 100, 3: 300, 5: 500, 6: 700}))
    ex, _ = _executor(clock, updates=2)
    ex.run(2, StopFlag())
    assert _per_component(ex) == [100, 300, 500, 700]
    assert _jitter_calc(ex)[1] == [400, 1200]


def test_feeders_count_in_the_iteration_not_in_the_first_component() -> None:
    # reads: 0 start; per iteration: t0, after the feeders, after update 0, after update 1
    clock = SimClock(cost_ns=_costs({2: 50, 3: 100, 4: 300}))
    ex, _ = _executor(clock, updates=2)
    fed: list[int] = []
    ex.feeders = (lambda: fed.append(clock._now),)
    ex.run(1, StopFlag())
    assert fed == [0]  # before the components, at the iteration's start
    assert _per_component(ex) == [100, 300]
    assert _jitter_calc(ex)[1] == [450]


def test_time_ns_is_relative_to_the_first_scheduled_start() -> None:
    clock = SimClock(123_456)
    ex, (probe,) = _executor(clock)
    ex.run(3, StopFlag())
    assert [t for _, t, _ in probe.seen] == [0, P, 2 * P]
    assert ex.origin_ns == 123_456


def test_absolute_policy_catches_up_back_to_back() -> None:
    # iteration 1's update takes 2.5 periods (read 4 is the end of its update)
    clock = SimClock(cost_ns=_costs({4: 5 * P // 2}))
    ex, (probe,) = _executor(clock, policy="absolute")
    starts: list[int] = []
    ex.idle = None
    ex.updates = (lambda: (starts.append(clock._now), probe()),)
    ex.run(5, StopFlag())
    jitter, calc = _jitter_calc(ex)
    # iteration 2 (due at 2P) and 3 (due at 3P) both start at 3.5P, back to back
    assert starts == [0, P, 7 * P // 2, 7 * P // 2, 4 * P]
    assert jitter == [0, 0, 3 * P // 2, P // 2, 0]
    assert calc == [0, 5 * P // 2, 0, 0, 0]
    # iteration 1 ended after 2P, iteration 2 ended after 3P
    assert _writer(ex).overruns == 2
    assert [r[COL_OVERRAN] for r in _rows(ex)] == [0, 1, 1, 0, 0]
    # scheduled times stay on the grid
    assert [t for _, t, _ in probe.seen] == [0, P, 2 * P, 3 * P, 4 * P]


def test_relative_policy_reanchors_after_an_overrun() -> None:
    clock = SimClock(cost_ns=_costs({4: 5 * P // 2}))
    ex, (probe,) = _executor(clock, policy="relative")
    starts: list[int] = []
    ex.updates = (lambda: (starts.append(clock._now), probe()),)
    ex.run(5, StopFlag())
    jitter, calc = _jitter_calc(ex)
    # iteration 1 ends at 3.5P; the next starts one period later, and so on
    assert starts == [0, P, 9 * P // 2, 11 * P // 2, 13 * P // 2]
    assert jitter == [0, 0, 0, 0, 0]
    assert calc == [0, 5 * P // 2, 0, 0, 0]
    assert _writer(ex).overruns == 1
    assert [t for _, t, _ in probe.seen] == [0, P, 9 * P // 2, 11 * P // 2, 13 * P // 2]


def test_calc_exactly_one_period_is_not_an_overrun() -> None:
    clock = SimClock(cost_ns=_costs({2: P}))
    ex, _ = _executor(clock)
    ex.run(2, StopFlag())
    assert _writer(ex).overruns == 0
    assert _jitter_calc(ex)[0] == [0, 0]


def test_late_wakeup_counts_as_overrun_when_it_ends_past_the_next_deadline() -> None:
    clock = SimClock(wake_latency_ns=[P + 1, 0, 0].__getitem__)
    ex, _ = _executor(clock)
    ex.run(3, StopFlag())
    jitter, _ = _jitter_calc(ex)
    assert jitter == [P + 1, 1, 0]
    assert _writer(ex).overruns == 1


def test_stop_flag_ends_after_the_current_iteration() -> None:
    ex, (probe,) = _executor(SimClock())
    stop = StopFlag()
    ex.idle = lambda: stop.set() if ex.state.iteration == 2 else None
    assert ex.run(None, stop) == 3
    assert [i for i, _, _ in probe.seen] == [0, 1, 2]
    assert stop.requested


def test_stop_flag_set_before_run_runs_nothing() -> None:
    ex, (probe,) = _executor(SimClock())
    stop = StopFlag()
    stop.set()
    assert ex.run(10, stop) == 0
    assert probe.seen == []
    assert _writer(ex).count == 0


def test_run_zero_iterations() -> None:
    ex, (probe,) = _executor(SimClock())
    assert ex.run(0, StopFlag()) == 0
    assert probe.seen == []


def test_idle_runs_after_each_recorded_iteration() -> None:
    ex, _ = _executor(SimClock())
    counts: list[int] = []
    ex.idle = lambda: counts.append(_writer(ex).ring.produced)  # the row is committed
    ex.run(3, StopFlag())
    assert counts == [1, 2, 3]


def test_update_failure_carries_index_iteration_and_time() -> None:
    state_holder: list[Executor] = []

    def bad() -> None:
        if state_holder[0].state.iteration == 3:
            raise ValueError("boom")

    ex, (probe,) = _executor(SimClock())
    ex.updates = (probe, bad)
    ex.timing = TimingWriter(["/a", "/b"], local_ring(2, 16))
    state_holder.append(ex)
    with pytest.raises(UpdateFailure) as info:
        ex.run(10, StopFlag())
    failure = info.value
    assert failure.index == 1
    assert failure.iteration == 3
    assert failure.time_ns == 3 * P
    assert isinstance(failure.error, ValueError)
    assert failure.__cause__ is failure.error
    assert ex.state.running is False
    assert _writer(ex).count == 3  # the failed iteration is not recorded
    assert [i for i, _, _ in probe.seen] == [0, 1, 2, 3]


def test_failure_in_first_update_has_index_zero() -> None:
    def bad() -> None:
        raise RuntimeError("x")

    ex, _ = _executor(SimClock())
    ex.updates = (bad,)
    with pytest.raises(UpdateFailure) as info:
        ex.run(1, StopFlag())
    assert (info.value.index, info.value.iteration, info.value.time_ns) == (0, 0, 0)


def test_idle_error_is_not_an_update_failure() -> None:
    ex, _ = _executor(SimClock())

    def idle() -> None:
        raise KeyError("idle")

    ex.idle = idle
    with pytest.raises(KeyError):
        ex.run(3, StopFlag())
    assert ex.state.running is False


def test_a_second_run_continues_iterations_and_the_time_grid() -> None:
    clock = SimClock(cost_ns=_costs({2: 40, 4: 40}))
    ex, (probe,) = _executor(clock)
    assert ex.run(2, StopFlag()) == 2
    assert ex.run(2, StopFlag()) == 2
    assert [(i, t) for i, t, _ in probe.seen] == [(0, 0), (1, P), (2, 2 * P), (3, 3 * P)]
    assert _writer(ex).count == 4
    assert _jitter_calc(ex)[0] == [0, 0, 0, 0]


def test_run_after_a_failure_resumes_at_the_next_slot() -> None:
    fail = [True]

    ex, (probe,) = _executor(SimClock())

    def flaky() -> None:
        if ex.state.iteration == 1 and fail[0]:
            fail[0] = False
            raise ValueError

    ex.updates = (probe, flaky)
    ex.timing = TimingWriter(["/a", "/b"], local_ring(2, 16))
    with pytest.raises(UpdateFailure):
        ex.run(5, StopFlag())
    ex.run(2, StopFlag())
    assert [(i, t) for i, t, _ in probe.seen] == [(0, 0), (1, P), (2, 2 * P), (3, 3 * P)]


def test_full_ring_drops_rows_and_counts_them() -> None:
    clock = SimClock(cost_ns=lambda n: n if n % 2 == 0 else 0)  # calc of iteration k: 2+2k
    ex, _ = _executor(clock, capacity=4)
    ex.run(6, StopFlag())
    timing = _writer(ex)
    assert timing.count == 6
    assert timing.ring.dropped == 2  # iterations 4 and 5 found the ring full
    assert [r[COL_ITERATION] for r in _rows(ex)] == [0, 1, 2, 3]
    assert _jitter_calc(ex)[1] == [2, 4, 6, 8]


def test_a_drained_ring_keeps_every_row() -> None:
    ex, _ = _executor(SimClock(), capacity=4)
    ex.idle = lambda: _rows(ex)
    ex.run(10, StopFlag())
    assert _writer(ex).ring.dropped == 0
    assert [r[COL_ITERATION] for r in _rows(ex)] == list(range(10))


def test_a_run_without_timing_writer_is_refused() -> None:
    ex, _ = _executor(SimClock())
    ex.timing = None
    with pytest.raises(RuntimeError, match="timing writer"):
        ex.run(1, StopFlag())


def test_stop_flag_lives_in_any_int64_cell() -> None:
    from array import array

    cell = array("q", [0])
    flag = StopFlag(cell)
    assert not flag.requested
    cell[0] = 2  # what a supervisor writes into shared memory
    assert flag.requested
    flag.clear()
    assert cell[0] == 0 and not flag.requested


class _SteppedClock:
    """A clock whose time the test sets; sleeping jumps to the deadline."""

    simulated = True

    def __init__(self, now: int) -> None:
        self.now = now

    def now_ns(self) -> int:
        return self.now

    def sleep_until_ns(self, deadline_ns: int) -> None:
        self.now = max(self.now, deadline_ns)


def test_a_run_stopped_before_its_first_iteration_does_not_start_the_time_grid() -> None:
    # a load request while the loop waits for its first /clock: the run ends at once
    clock = _SteppedClock(0)
    state = LoopState(1000.0)
    probe = Probe(state)
    ex = Executor([probe], clock, state, TimingWriter(["/c0"], local_ring(1, 16)))
    stop = StopFlag()
    stop.set(2)
    assert ex.run(3, stop) == 0
    clock.now = 50 * 10**9  # /clock arrives, at 50 s
    stop.set(0)
    assert ex.run(2, stop) == 2
    assert [(i, t) for i, t, _ in probe.seen] == [(0, 0), (1, P)]
