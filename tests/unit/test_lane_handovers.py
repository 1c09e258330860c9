"""Values crossing lanes (rtcf._runtime._lanes's handovers): the compiled one
(rtcf._core._compiled.Handover) and the Python path's classes, side by side, each in
one process with two lanes' links on one buffer: what a reader gets, and what it counts
(late, lost, LET overruns) when the value is not there."""

from __future__ import annotations

import gc
import sys
import threading
import tracemalloc
from array import array
from collections.abc import Callable, Iterator
from contextlib import closing
from types import ModuleType
from typing import Any

import pytest

from rtcf._core import _interpreted
from rtcf._core._executor import StopFlag
from rtcf._core._lanes import LET_IN, LET_OUT, RECV, SEND, TAKE, Lane, Step
from rtcf._runtime import _lanes
from rtcf._runtime._lanes import (
    L_LAST,
    L_TAKEN,
    W_FIRST,
    W_ORIGIN_NS,
    W_STOP_AT,
    LaneLink,
    init_words,
    layout,
)
from rtcf._runtime._shm import Segment

try:
    from rtcf._core import _compiled  # type: ignore[attr-defined]
except ImportError as exc:  # a failure, not a skip: CI builds it
    raise AssertionError(f"rtcf._core._compiled is not built: {exc}") from None

PATHS = [pytest.param(_compiled, id="compiled"), pytest.param(_interpreted, id="Python")]
TYPES = {"float": (float, 8), "int": (int, 8), "bool": (bool, 1), "str": (str, 16)}


@pytest.fixture(params=PATHS)
def m(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[ModuleType]:
    """The hot path's module: its slots and loop state, and its handovers."""
    module = request.param
    monkeypatch.setattr(_lanes, "Handover", module.Handover)
    yield module


class Pair:
    """Lane ``main`` produces topic /x (of ``kind``), lane ``b`` reads it; ``every`` > 1
    puts the producer on logical execution time (lane ``let``)."""

    def __init__(self, m: ModuleType, kind: str, *, simulated: bool = True,
                 every: int = 1, now: Callable[[], int] = lambda: 0) -> None:
        cls, size = TYPES[kind]
        producer_lane = "let" if every > 1 else "main"
        reader_lane = "main" if every > 1 else "b"
        lanes = {"main": Lane("main", ()), producer_lane: Lane(producer_lane, (), every, 1)}
        if reader_lane not in lanes:
            lanes[reader_lane] = Lane(reader_lane, ())
        self.layout = layout(lanes, {"/x": (producer_lane, size)})
        self.seg = Segment.create(self.layout.size, "handover-test")
        init_words(self.seg.buf, self.layout)
        self.words = self.seg.buf.cast("q")
        self.words[W_FIRST] = 0
        self.links = {}
        for lane in (producer_lane, reader_lane):
            link = LaneLink(self.seg.buf, self.layout, lane, simulated=simulated,
                            period_ns=1_000_000)
            link.bound(m.LoopState(1000.0), StopFlag(array("q", [0])), now)
            self.links[lane] = link
        self.producer, self.reader = self.links[producer_lane], self.links[reader_lane]
        self.out = m.OutputPort("/p", "out", cls, self.producer.state)
        self.out.topic = "/x"
        self.stub = m.OutputPort("/r", "out", cls)  # the readers' slot
        self.stub.topic = "/x"
        self.send = self.producer.bind(Step(LET_OUT if every > 1 else SEND, "/x"), self.out)
        self.recv = self.reader.bind(
            Step(LET_IN if every > 1 else RECV, "/x", False, producer_lane), self.stub)

    def produce(self, i: int, value: Any = None) -> None:
        self.producer.state.iteration = i
        if value is not None:
            self.out.write(value)
        self.send()

    def receive(self, i: int) -> tuple[Any, int, int]:
        self.reader.state.iteration = i
        self.recv()
        slot = self.stub._slot
        return slot.value, slot.seq, slot.iteration

    def counts(self) -> dict[str, dict[str, int]]:
        return self.reader.counts()

    def close(self) -> None:
        for link in self.links.values():
            link.release()
        self.words.release()
        self.seg.close()  # a view left alive would refuse this


@pytest.mark.parametrize("kind, values", [
    ("float", [1.5, -0.25, 7]), ("int", [3, -9, True]), ("bool", [True, False, 2]),
    ("str", ["a", "", "grüße"]),
])
def test_a_reader_in_another_lane_gets_each_iterations_value(
    m: ModuleType, kind: str, values: list[Any]
) -> None:
    cls = TYPES[kind][0]
    with closing(Pair(m, kind)) as pair:
        assert (type(pair.send) is _compiled.Handover) == (m is _compiled)
        for i, v in enumerate(values):
            pair.produce(i, v)
            assert pair.receive(i) == (cls(v), i + 1, i)
        assert pair.counts() == {}


def test_a_value_never_written_crosses_as_none(m: ModuleType) -> None:
    with closing(Pair(m, "float")) as pair:
        pair.produce(0)
        assert pair.receive(0) == (None, 0, -1)


def test_a_value_too_large_for_its_channel_is_refused_and_leaves_the_entry(
    m: ModuleType,
) -> None:
    with closing(Pair(m, "str")) as pair:
        pair.produce(0, "fits")
        pair.out.write("x" * 17)
        with pytest.raises(ValueError, match="17 bytes is larger than a lane's channel holds"):
            pair.produce(4)  # the same entry as iteration 0 (DEPTH 4)
        assert pair.receive(0) == ("fits", 1, 0)


def test_in_real_time_a_value_not_there_by_the_periods_end_is_late(m: ModuleType) -> None:
    t = [0]
    with closing(Pair(m, "float", simulated=False, now=lambda: t[0])) as pair:
        pair.produce(0, 1.0)
        assert pair.receive(0) == (1.0, 1, 0)
        pair.words[W_ORIGIN_NS] = 0
        pair.reader.state.time_ns = 1_000_000
        t[0] = 2_000_001  # past the end of iteration 1's period: it will not wait
        assert pair.receive(1) == (1.0, 1, 0)  # the previous value stays
        assert pair.counts() == {"@recv /x": {"late": 1}}


def test_a_reader_that_fell_behind_counts_the_value_lost(m: ModuleType) -> None:
    with closing(Pair(m, "int")) as pair:
        for i in range(5):  # iteration 4 overwrote iteration 0's entry
            pair.produce(i, 10 + i)
        assert pair.receive(0) == (None, 0, -1)
        assert pair.counts() == {"@recv /x": {"lost": 1}}
        assert pair.receive(4) == (14, 5, 4)


def test_a_wait_ends_when_the_producer_finished_the_iteration_without_it(
    m: ModuleType,
) -> None:
    with closing(Pair(m, "float")) as pair:
        pair.produce(0, 2.0)
        pair.receive(0)
        # the producer says it is done with 1 without sending it (a failure ended it)
        pair.words[pair.producer.base + L_LAST] = 1
        assert pair.receive(1) == (2.0, 1, 0)
        pair.words[W_STOP_AT] = 1  # the lanes stop after 1: no wait for 2 either
        assert pair.receive(2) == (2.0, 1, 0)
        assert pair.counts() == {}


def test_a_let_lanes_output_shows_when_its_window_ends(m: ModuleType) -> None:
    with closing(Pair(m, "float", every=4)) as pair:  # released at 1, 5, 9 ...
        pair.produce(1, 3.0)  # release 1's output
        assert [pair.receive(i)[0] for i in (2, 3, 4)] == [None, None, None]
        assert pair.receive(5) == (3.0, 1, 1)  # window 1-4 ended
        assert pair.receive(6) == (3.0, 1, 1)


def test_in_real_time_a_let_lane_not_done_by_its_window_end_is_an_overrun(
    m: ModuleType,
) -> None:
    with closing(Pair(m, "float", simulated=False, every=4)) as pair:
        pair.produce(1, 3.0)
        assert pair.receive(5) == (3.0, 1, 1)
        assert pair.receive(9) == (3.0, 1, 1)  # release 5 did not finish
        assert pair.receive(10) == (3.0, 1, 1)  # counted once per window
        assert pair.counts() == {"@let_in /x": {"let_overruns": 1}}


def test_no_reference_or_memory_is_leaked_by_handovers(m: ModuleType) -> None:
    with closing(Pair(m, "str")) as pair:
        value = "a value"  # what crosses is a copy: only the slot's writes refer to it
        slots = (pair.out._slot, pair.stub._slot, pair.reader.state)

        def run(first: int, n: int) -> None:
            for i in range(first, first + n):
                pair.produce(i, value)
                pair.receive(i)

        run(0, 1000)
        before = sys.getrefcount(value), *map(sys.getrefcount, slots)
        tracemalloc.start()
        try:
            grown = tracemalloc.get_traced_memory()[0]
            run(1000, 100_000)  # a value leaked per handover would be 5 MB
            grown = tracemalloc.get_traced_memory()[0] - grown
        finally:
            tracemalloc.stop()
        assert pair.stub._slot.value == value and pair.stub._slot.seq == 101_000
        gc.collect()
        assert (sys.getrefcount(value), *map(sys.getrefcount, slots)) == before
        assert grown < 64 * 1024


def test_a_let_lanes_first_take_is_not_lost_to_a_main_lane_run_ahead(
    m: ModuleType,
) -> None:
    # A fresh segment on a simulated clock: lane ``let`` (every 4, phase 0) takes /x as
    # main's iteration i - 1 left it. Main may not run past the let lane's release 0
    # before it took its inputs: it waits for it after iteration 0. Before, the let
    # lane said which release it had taken only after the run began, and the fresh
    # segment's 0 let main run 0-3 at once, overwriting entry 3 before release 0 read
    # it: its take of iteration -1 (nothing yet) counted the value lost.
    lanes = {"main": Lane("main", ()), "let": Lane("let", (), 4, 0)}
    lay = layout(lanes, {"/x": ("main", 8)})
    seg = Segment.create(lay.size, "handover-test")
    init_words(seg.buf, lay)
    words = seg.buf.cast("q")
    main = LaneLink(seg.buf, lay, "main", simulated=True, period_ns=1_000_000)
    let = LaneLink(seg.buf, lay, "let", simulated=True, period_ns=1_000_000)
    for link in (main, let):
        link.bound(m.LoopState(1000.0), StopFlag(array("q", [0])), lambda: 0)
    out = m.OutputPort("/p", "out", float, main.state)
    out.topic = "/x"
    stub = m.OutputPort("/r", "in", float)  # the let lane's readers' slot
    stub.topic = "/x"
    send = main.bind(Step(SEND, "/x"), out)
    take = let.bind(Step(TAKE, "/x", True, "main"), stub)
    go = threading.Event()
    failures: list[BaseException] = []

    def let_lane() -> None:  # begins, is held where the run has begun, then release 0
        try:
            let.begin(1, 0, None, lambda *_: go.wait(10))
            let.state.iteration = 0
            let.feeder()
            take()
            let.after()
        except BaseException as exc:  # the test reports it
            failures.append(exc)

    def main_lane() -> None:
        try:
            for i in range(5):
                main.state.iteration = i
                main.feeder()
                out.write(float(i))
                send()
                main.after()
        except BaseException as exc:
            failures.append(exc)

    other = threading.Thread(target=let_lane, daemon=True)
    runner = threading.Thread(target=main_lane, daemon=True)
    other.start()
    try:
        main.begin(1, 0, None, lambda *_: None, 5)  # every lane ready: the run begins
        # the let lane is ready, its release 0 not run: main must wait after iteration 0
        taken = words[let.base + L_TAKEN]
        runner.start()
        runner.join(0.2)
        waited = runner.is_alive()
    finally:
        go.set()
        other.join(5)
        if runner.ident is not None:
            runner.join(5)
    try:
        assert not other.is_alive() and not runner.is_alive() and failures == []
        assert let.counts() == {}
        assert (stub._slot.value, stub._slot.seq) == (None, 0)  # nothing before iteration 0
        assert taken < 0 and waited, "main ran ahead of the let lane's first release"
    finally:
        for link in (main, let):
            link.release()
        words.release()
        seg.close()
