"""The loop's hot path, compiled (rtcf._core._compiled) and in Python
(rtcf._core._interpreted), side by side: the same semantics, call for call.

Whichever one rtcf runs (RTCF_PURE_PYTHON), both are tested here; the compiled one
must have been built (CI has a C compiler everywhere it runs).
"""

from __future__ import annotations

import gc
import os
import sys
from array import array
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from rtcf._core import _hotpath, _interpreted
from rtcf._core._ports import FlowStatus
from rtcf._core._timing import CALCULATION_COLUMNS, FIXED_COLUMNS

try:
    from rtcf._core import _compiled  # type: ignore[attr-defined]
except ImportError as exc:  # a failure, not a skip: CI builds it
    raise AssertionError(f"rtcf._core._compiled is not built: {exc}") from None

MODULES = [pytest.param(_compiled, id="compiled"), pytest.param(_interpreted, id="Python")]
COLUMNS = CALCULATION_COLUMNS  # iteration, scheduled, jitter, calc, phase (4: overran)
F = FIXED_COLUMNS  # the first component's column


def _ports(m: ModuleType) -> tuple[Any, Any]:
    """An output and an input of the module, wired to one slot."""
    m.set_flow_status(
        FlowStatus.NO_DATA, FlowStatus.OLD_DATA, FlowStatus.NEW_DATA, FlowStatus.EXPIRED
    )
    st = m.LoopState(100.0)
    out = m.OutputPort("/c", "out", float, st)
    inp = m.InputPort("/d", "in", float)
    inp._connect(out)
    return out, inp


def test_the_path_rtcf_runs_is_one_of_them_and_says_which() -> None:
    assert _hotpath.Slot in (_compiled.Slot, _interpreted.Slot)
    compiled = _hotpath.Slot is _compiled.Slot
    assert _hotpath.HOT_PATH == ("compiled" if compiled else "Python")
    assert _hotpath.describe().startswith("compiled (C)" if compiled else "Python (")


@pytest.mark.parametrize("m", MODULES)
def test_a_slot_starts_empty(m: ModuleType) -> None:
    s = m.Slot()
    assert (s.value, s.seq, s.iteration) == (None, 0, -1)
    s.value, s.seq, s.iteration = 2.5, 3, 7
    assert (s.value, s.seq, s.iteration) == (2.5, 3, 7)


@pytest.mark.parametrize("m", MODULES)
def test_loop_state(m: ModuleType) -> None:
    st = m.LoopState(3.0)
    assert st.frequency == 3.0 and st.period_ns == round(1e9 / 3.0)
    assert (st.iteration, st.time_ns, st.stamp_ns, st.running) == (-1, 0, 0, False)
    assert m.LoopState().period_ns == 1_000_000_000
    with pytest.raises(ValueError, match="frequency must be positive"):
        m.LoopState(0.0)


@pytest.mark.parametrize("m", MODULES)
def test_write_read_status_and_iteration(m: ModuleType) -> None:
    out, inp = _ports(m)
    st = out._state
    assert inp._slot is out._slot and inp.connected and inp.producer is out
    assert inp.status is FlowStatus.NO_DATA and not inp.has_new_data and inp.iteration == -1
    assert inp.read() is None and inp.status is FlowStatus.NO_DATA
    st.iteration = 4
    value = object()
    out.write(value)
    assert inp.status is FlowStatus.NEW_DATA and inp.has_new_data and inp.iteration == 4
    assert inp.read() is value
    assert inp.status is FlowStatus.OLD_DATA and not inp.has_new_data
    out.write(None)  # a write of None is a write
    assert inp.status is FlowStatus.NEW_DATA and inp.read() is None
    assert out._slot.seq == 2 and inp._seen == 2


@pytest.mark.parametrize("m", MODULES)
def test_an_input_past_its_deadline_says_expired_until_the_watch_clears_it(
    m: ModuleType,
) -> None:
    out, inp = _ports(m)
    assert inp.deadline is None and inp._deadline_ns == 0 and not inp._expired
    inp._deadline_ns = 250_000_000
    assert inp.deadline == 0.25
    assert inp.status is FlowStatus.NO_DATA
    out.write(1.0)
    inp._expired = inp._slot.seq  # the watch found this value past its deadline
    assert inp.status is FlowStatus.EXPIRED and inp.has_new_data  # EXPIRED before NEW_DATA
    assert inp.read() == 1.0 and inp.status is FlowStatus.EXPIRED
    out.write(2.0)  # a new value (earlier in the iteration): new data at once
    assert inp.status is FlowStatus.NEW_DATA and inp._expired == 1
    assert inp.read() == 2.0 and inp.status is FlowStatus.OLD_DATA
    inp._expired = 0  # the watch clears it at the next boundary
    assert inp.status is FlowStatus.OLD_DATA


@pytest.mark.parametrize("m", MODULES)
def test_names_repr_and_direction(m: ModuleType) -> None:
    out, inp = _ports(m)
    assert (out.component, out.name, out.type, out.topic) == ("/c", "out", float, "")
    assert out.qualified_name == "/c.out" and inp.qualified_name == "/d.in"
    assert (out.direction, inp.direction) == ("output", "input")
    assert repr(out) == "<OutputPort /c.out -> ? [float]>"
    inp.topic = "/x"
    assert repr(inp) == "<InputPort /d.in <- /x [float]>"
    assert isinstance(out, m.Port) and isinstance(inp, m.Port)
    assert not hasattr(inp, "write") and not hasattr(out, "read")
    assert m.OutputPort[float] is not None  # generic, as typing sees it


@pytest.mark.parametrize("m", MODULES)
def test_connect_shares_a_slot_or_keeps_or_gets_its_own(m: ModuleType) -> None:
    out, inp = _ports(m)
    out.write(1.0)
    inp.read()
    fed = inp._slot
    inp._connect(None)  # disconnected: a fresh slot, nothing seen
    assert inp._slot is not fed and inp._seen == 0 and not inp.connected
    mine = inp._slot
    mine.value, mine.seq = 5.0, 1  # a bridge fed it
    inp._connect(None)  # stays unconnected: keeps what it was fed
    assert inp._slot is mine and inp.read() == 5.0


@pytest.mark.parametrize("m", MODULES)
def test_a_port_outside_a_loop_records_iteration_minus_one(m: ModuleType) -> None:
    out = m.OutputPort("/c", "out", float)
    assert out._state is None and out._tap is None
    out.write(1.0)
    assert out._slot.iteration == -1 and out._slot.seq == 1
    st = m.LoopState()
    st.iteration = 9
    out._state = st
    out.write(2.0)
    assert out._slot.iteration == 9 and out._state is st
    out._state = None
    out.write(3.0)
    assert out._slot.iteration == -1


@pytest.mark.parametrize("m", MODULES)
def test_a_tapped_write_hands_the_value_to_the_tap_after_the_slot(m: ModuleType) -> None:
    out = m.OutputPort("/c", "out", float)
    seen: list[tuple[Any, int]] = []
    out.write(1.0)
    out._tap = lambda v: seen.append((v, out._slot.seq))  # mapped or recorded
    out.write(2.0)
    assert seen == [(2.0, 2)]
    out._tap = None
    out.write(3.0)
    assert out._slot.value == 3.0 and seen == [(2.0, 2)]
    out._tap = lambda v: 1 / 0
    with pytest.raises(ZeroDivisionError):
        out.write(4.0)
    assert out._slot.value == 4.0  # the slot has it: the tap failed after


def test_the_compiled_port_refuses_what_is_not_its_slot_state_or_producer() -> None:
    out = _compiled.OutputPort("/c", "out", float)
    with pytest.raises(TypeError, match="_slot must be a Slot"):
        out._slot = object()
    with pytest.raises(TypeError, match="_state must be a LoopState or None"):
        out._state = object()
    with pytest.raises(TypeError, match="producer must be an OutputPort"):
        _compiled.InputPort("/d", "in", float)._connect(object())


class _Executor:
    def __init__(self, plans: tuple[Any, ...]) -> None:
        self.plans = plans


def _calculation(
    m: ModuleType, plans: tuple[Any, ...], feeders: tuple[Callable[[], object], ...] = (),
    width: int = F + 3, slots: int = 4,
) -> tuple[Any, Any, array[int], array[int], array[int], list[int]]:
    clock = [1000]  # a clock that moves 10 ns per read
    sleeps: list[int] = []

    def now() -> int:
        clock[0] += 10
        return clock[0]

    def sleep_until(deadline: int) -> None:
        sleeps.append(deadline)
        clock[0] = max(clock[0], deadline)

    st = m.LoopState(1000.0)
    running = array("q", [-1])
    words = array("q", bytes(8 * width * slots))
    scratch = array("q", bytes(8 * width))
    calc = m.Calculation(
        _Executor(plans), st, feeders, now, sleep_until, False, False, running, words, scratch,
        500, 7, width, COLUMNS,
    )
    return calc, st, running, words, scratch, sleeps


@pytest.mark.parametrize("m", MODULES)
def test_an_iteration_sleeps_runs_its_phases_plan_and_fills_its_row(m: ModuleType) -> None:
    calls: list[tuple[str, int]] = []
    st_box: list[Any] = []

    def upd(name: str) -> Callable[[], None]:
        return lambda: calls.append((name, st_box[0].iteration))

    a, b, c = upd("a"), upd("b"), upd("c")
    plans = (((F, a), (F + 1, b), (F + 2, c)), ()), (((F, a), (F + 2, c)), (F + 1,))
    fed: list[int] = []
    calc, st, running, words, scratch, sleeps = _calculation(
        m, plans, feeders=(lambda: fed.append(1),)
    )
    st_box.append(st)
    w = F + 3
    t = calc.iterate(3, 2000, w)  # phase 1 (3 % 2), into the second row
    assert sleeps == [2000]
    assert calls == [("a", 3), ("c", 3)] and fed == [1]
    assert (st.iteration, st.time_ns, st.stamp_ns) == (3, 2000 - 500, 2000 + 7)
    row = words[w : 2 * w]
    # read after the sleep (2010), after the feeders (2020), after a (2030) and c (2040)
    assert t == 2040
    assert row[0] == 3 and row[1] == 2000 and row[2] == 10 and row[3] == 30 and row[5] == 1
    assert row[F] == 10 and row[F + 1] == -1 and row[F + 2] == 10
    assert running[0] == -1
    assert scratch.tolist() == [0] * w
    calls.clear()
    calc.iterate(4, 3000, -1)  # ring full: the scratch row
    assert calls == [("a", 4), ("b", 4), ("c", 4)]
    assert scratch[0] == 4 and scratch[5] == 0 and scratch[F + 1] == 10
    calc.release()
    with pytest.raises((RuntimeError, TypeError)):
        calc.iterate(5, 4000, 0)


@pytest.mark.parametrize("m", MODULES)
def test_an_update_that_raises_leaves_its_column_in_the_running_word(m: ModuleType) -> None:
    def boom() -> None:
        raise KeyError("x")

    plans = ((((F, lambda: None), (F + 1, boom)), ()),)
    calc, st, running, *_ = _calculation(m, plans)
    with pytest.raises(KeyError):
        calc.iterate(0, 2000, 0)
    assert running[0] == F + 1 and st.iteration == 0
    calc.release()


@pytest.mark.parametrize("m", MODULES)
def test_a_plan_swapped_by_a_feeder_applies_in_the_same_iteration(m: ModuleType) -> None:
    ran: list[str] = []
    first = ((((F, lambda: ran.append("old")),), ()),)
    second = ((((F, lambda: ran.append("new")),), ()),)
    ex = _Executor(first)
    calc = m.Calculation(
        ex, m.LoopState(), (lambda: setattr(ex, "plans", second),), lambda: 0, lambda d: None,
        False, False, array("q", [-1]), array("q", bytes(8 * (F + 3))),
        array("q", bytes(8 * (F + 3))), 0, 0, F + 3, COLUMNS,
    )
    calc.iterate(0, 0, 0)
    assert ran == ["new"]


@pytest.mark.parametrize("per_cycle", ["measured", 0.0])
def test_on_clock_monotonic_components_are_timed_by_the_cycle_counter_in_nanoseconds(
    per_cycle: Any,
) -> None:
    """Where the TSC times components (the kernel's clocksource), each column is still
    nanoseconds: a 2 ms sleep in one update and nothing in the other are told apart by
    their size, and the iteration's start and end stay on CLOCK_MONOTONIC."""
    import time

    ns = _compiled.ns_per_cycle() if per_cycle == "measured" else per_cycle
    plans = ((((F, lambda: time.sleep(0.002)), (F + 1, lambda: None)), ()),)
    width = F + 3
    words = array("q", bytes(8 * width))
    calc = _compiled.Calculation(
        _Executor(plans), _compiled.LoopState(1000.0), (), time.monotonic_ns,
        lambda d: None, True, True, array("q", [-1]), words, array("q", bytes(8 * width)),
        0, 0, width, COLUMNS, ns,
    )
    deadline = time.monotonic_ns()
    t = calc.iterate(0, deadline, 0)
    after = time.monotonic_ns()
    assert deadline <= t <= after  # the end: CLOCK_MONOTONIC
    slept, nothing = words[F], words[F + 1]
    assert 2_000_000 <= slept < 50_000_000, slept
    assert 0 <= nothing < 200_000, nothing
    assert words[3] >= slept  # the iteration's calculation covers its components
    calc.release()


def test_the_component_clock_is_the_tsc_exactly_where_the_kernel_uses_it() -> None:
    which, per_cycle = _hotpath.component_clock()
    try:
        with open(_hotpath._CLOCKSOURCE) as f:
            source = f.read().strip()
    except OSError:
        source = ""
    tsc = source == "tsc" and _hotpath.HOT_PATH == "compiled" and os.environ.get(
        "RTCF_COMPONENT_CLOCK", "") == "" and \
        _compiled.ns_per_cycle() > 0
    assert (which, per_cycle > 0) == (("TSC", True) if tsc else ("CLOCK_MONOTONIC", False))
    if tsc:  # a plausible counter: between 100 MHz and 10 GHz
        assert 0.1 < per_cycle < 10.0


def test_the_compiled_plans_hold_their_updates_only_while_they_are_the_executors() -> None:
    """The compiled Calculation keeps executor.plans as arrays (a bound method as its
    function and self) until the plans change: swapped every iteration a thousand
    times, no reference is leaked, and once it is gone none is left."""

    class Component:
        def __init__(self) -> None:
            self.calls = 0

        def update(self) -> None:
            self.calls += 1

    a, b = Component(), Component()
    plans_a = ((((F, a.update),), ()),)
    plans_b = ((((F + 1, b.update),), (F,)),)
    ex = _Executor(plans_a)
    base_a, base_b = sys.getrefcount(a), sys.getrefcount(b)
    calc = _compiled.Calculation(
        ex, _compiled.LoopState(), (), lambda: 0, lambda d: None, False, False,
        array("q", [-1]), array("q", bytes(8 * (F + 3))), array("q", bytes(8 * (F + 3))),
        0, 0, F + 3, COLUMNS,
    )
    for k in range(1000):
        ex.plans = plans_a if k % 2 == 0 else plans_b
        calc.iterate(k, 0, 0)
    assert (a.calls, b.calls) == (500, 500)
    # the last plans (b's) are held, compiled: its function and self, once more
    assert sys.getrefcount(a) == base_a
    assert sys.getrefcount(b) == base_b + 1
    del calc
    gc.collect()
    assert (sys.getrefcount(a), sys.getrefcount(b)) == (base_a, base_b)


def test_the_compiled_calculation_refuses_rows_and_plans_outside_its_words() -> None:
    calc, *_ = _calculation(_compiled, ((((F + 9, lambda: None),), ()),), slots=1)
    with pytest.raises(IndexError):
        calc.iterate(0, 0, 0)  # a column past the row
    calc, *_ = _calculation(_compiled, ((((F, lambda: None),), ()),), slots=1)
    with pytest.raises(IndexError):
        calc.iterate(0, 0, 1)  # a row past the ring
    calc, *_ = _calculation(_compiled, ("not a plan",), slots=1)
    with pytest.raises(TypeError, match="plans"):
        calc.iterate(0, 0, 0)


@pytest.mark.parametrize("m", MODULES)
def test_a_ring_gate_calls_only_when_the_counters_differ(m: ModuleType) -> None:
    words = array("q", [0, 0, 0])
    calls: list[int] = []
    gate = m.RingGate(words, 0, 2, lambda: calls.append(1))
    gate()
    assert calls == []
    words[0] = 1
    gate()
    assert calls == [1]
    gate.release()
    gate()
    assert calls == [1]


def _gate_trace(m: ModuleType) -> list[tuple[int, bool, list[int], list[int]]]:
    """A deadline gate of the module over two inputs, 12 iterations: per iteration,
    whether it called its fn, and its seqs and due times after."""
    out, inp = _ports(m)
    out2, inp2 = _ports(m)
    st = m.LoopState(100.0)
    inp._deadline_ns, inp2._deadline_ns = 25_000_000, 40_000_000
    never = sys.maxsize
    seq, due = array("q", [0, 0]), array("q", [never, never])
    called: list[int] = []

    def fn() -> None:  # what the watch does, in short: expire, or clear
        called.append(st.iteration)
        for k, p in enumerate((inp, inp2)):
            if p._slot.seq != seq[k]:
                seq[k], due[k], p._expired = p._slot.seq, st.time_ns + p._deadline_ns, False
            elif st.time_ns > due[k]:
                p._expired, due[k] = True, never

    gate = m.DeadlineGate(st, (inp, inp2), seq, due, fn)
    trace = []
    for i in range(12):
        st.iteration, st.time_ns = i, i * 10_000_000
        if i < 3 or i >= 9:
            out.write(float(i))
        if i < 2:
            out2.write(float(i))
        gate()
        trace.append((i, called[-1:] == [i], list(seq), list(due)))
    gate.release()
    gate()  # released: does nothing
    assert len(called) == len([t for t in trace if t[1]])
    return trace


def test_a_deadline_gate_calls_only_when_an_input_passes_its_due_time_or_comes_back() -> None:
    compiled, python = _gate_trace(_compiled), _gate_trace(_interpreted)
    assert compiled == python  # side by side, iteration by iteration
    # /in: last at 20 ms, past 45 ms at 5, back at 9; /in2: last at 10 ms, past 50 at 6
    assert [i for i, c, _, _ in compiled if c] == [5, 6, 9]
    assert compiled[2][2:] == ([3, 2], [45_000_000, 50_000_000])
    assert compiled[9][2:] == ([4, 2], [115_000_000, sys.maxsize])


def test_the_compiled_deadline_gate_refuses_what_is_not_an_input_or_words() -> None:
    out, inp = _ports(_compiled)
    st = _compiled.LoopState(100.0)
    words = array("q", [0])
    with pytest.raises(TypeError, match="InputPorts"):
        _compiled.DeadlineGate(st, (out,), words, words, print)
    with pytest.raises(IndexError, match="fewer words than ports"):
        _compiled.DeadlineGate(st, (inp, inp), words, words, print)
    with pytest.raises(TypeError):
        _compiled.DeadlineGate(st, (inp,), array("d", [0.0]), words, print)


def test_the_compiled_deadline_gate_leaks_nothing_and_dies_in_a_cycle() -> None:
    out, inp = _ports(_compiled)
    st = _compiled.LoopState(100.0)
    inp._deadline_ns = 1
    seq, due = array("q", [0]), array("q", [0])

    class Check:  # the watch's check: it holds the gate, the gate holds it
        gate: Any = None

        def __call__(self) -> None:
            due[0] = sys.maxsize

    before = sys.getrefcount(inp), sys.getrefcount(st)
    check = Check()
    check.gate = _compiled.DeadlineGate(st, (inp,), seq, due, check)
    with pytest.raises(BufferError):  # it holds the words
        seq.append(0)
    gate = check.gate
    for i in range(100_000):
        st.time_ns = i
        if i % 3 == 0:
            out.write(1.0)
        gate()
    del gate, check  # the cycle: only the collector frees it
    gc.collect()
    assert (sys.getrefcount(inp), sys.getrefcount(st)) == before
    seq.append(0)  # and it let go of the words


@pytest.mark.parametrize("m", MODULES)
def test_no_reference_is_leaked_by_a_million_writes_and_reads(m: ModuleType) -> None:
    out, inp = _ports(m)
    st = out._state
    value = object()
    tap = object.__new__(type("Sink", (), {"__call__": lambda self, v: None}))
    before = sys.getrefcount(value), sys.getrefcount(st), sys.getrefcount(tap)
    write, read = out.write, inp.read
    for _ in range(1_000_000):
        write(value)
        read()
    out._tap = tap
    for _ in range(1000):
        out.write(value)
    out._tap = None
    out.write(None)
    gc.collect()
    assert (sys.getrefcount(value), sys.getrefcount(st), sys.getrefcount(tap)) == before


def _records(ring: Any) -> list[tuple[int, int, int, bytes]]:
    out = []
    while (rec := ring.pop()) is not None:
        b = bytes(rec)
        words = array("q", b[:24])
        out.append((words[0], words[1], words[2], b[24 : 24 + words[0]]))
    return out


@pytest.mark.parametrize("kind, values", [
    ("float", [1.5, -0.25, 7]), ("int", [3, -9, True]), ("bool", [True, False, 2]),
])
def test_the_compiled_word_tap_pushes_what_the_python_tap_pushes(
    kind: str, values: list[Any]
) -> None:
    from rtcf._core._rings import Ring
    from rtcf._runtime._codec import codec_for
    from rtcf._runtime._recording import _WordRecordTap

    codec = codec_for({"float": float, "int": int, "bool": bool}[kind])
    got = []
    for compiled in (True, False):
        buf = bytearray(Ring.nbytes(4, 64))
        ring = Ring.create(buf, 4, 64)
        st = _hotpath.LoopState(100.0)
        tap = _WordRecordTap(ring, codec, st, wait=False)
        if compiled:  # the port's write calls it (compiled where the path is)
            assert (tap.call is not tap) == (_hotpath.HOT_PATH == "compiled")
        call = tap.call if compiled else tap.__call__
        for k, v in enumerate(values):
            st.iteration, st.stamp_ns = k, 1000 + k
            call(v)
        got.append(_records(ring))
        tap.release()
    assert got[0] == got[1] and len(got[0]) == len(values)


def test_a_full_ring_counts_the_drop_and_a_bad_value_leaves_it_as_it_was() -> None:
    from rtcf._core._rings import Ring

    buf = bytearray(Ring.nbytes(2, 32))
    ring = Ring.create(buf, 2, 32)
    tap = _compiled.WordTap(ring._ctl, ring.data, 8, 9, 16, 2, 32, _compiled.LoopState(), "float")
    for v in (1.0, 2.0, 3.0):
        tap(v)
    assert ring.dropped == 1 and tap.dropped == 1 and len(ring) == 2
    ring.pop()
    with pytest.raises(TypeError):
        tap("not a number")
    assert len(ring) == 1
    tap(4.0)
    assert len(ring) == 2
    tap.release()
    tap(5.0)  # released: nothing happens
    assert len(ring) == 2


def test_what_the_loop_prefetches_is_a_hint_that_changes_nothing_and_holds_nothing() -> None:
    """The compiled loop prefetches each upcoming component's object, values, ports and
    slots, found when the plans are compiled. Whatever a component holds there (a
    real port table, one that is not a dict, a lookup that raises, ports rewired or
    freed since), every update runs as it would without, no exception is left behind,
    and no reference to a port or slot is taken."""

    class Chain:
        def __init__(self, src: Any) -> None:
            self._rtcf_inputs = {"in": _compiled.InputPort("/c", "in", float)}
            self._rtcf_outputs = {"out": _compiled.OutputPort("/c", "out", float)}
            self._rtcf_inputs["in"]._connect(src)

        def update(self) -> None:
            self._rtcf_outputs["out"].write((self._rtcf_inputs["in"].read() or 0.0) + 1.0)

    looked_up: list[str] = []

    class Odd:
        _rtcf_inputs = [1, 2]  # not a dict

        def __getattr__(self, name: str) -> Any:
            looked_up.append(name)  # a component's own __getattr__: not for a hint
            raise AttributeError(name)

        def update(self) -> None:
            pass

    class NoTables:
        __slots__ = ()

        def update(self) -> None:
            pass

    head = _compiled.OutputPort("/h", "out", float)
    chain = [Chain(head)]
    for _ in range(9):
        chain.append(Chain(chain[-1]._rtcf_outputs["out"]))
    ports = [p for c in chain for t in (c._rtcf_inputs, c._rtcf_outputs) for p in t.values()]
    before = [sys.getrefcount(p) for p in ports]
    updates = [c.update for c in chain[:5]] + [Odd().update, NoTables().update]
    updates += [c.update for c in chain[5:]]
    plans = ((tuple((F + k, u) for k, u in enumerate(updates)), ()),)
    width = F + len(updates)
    calc = _compiled.Calculation(
        _Executor(plans), _compiled.LoopState(), (), lambda: 0, lambda d: None, False, False,
        array("q", [-1]), array("q", bytes(8 * width)), array("q", bytes(8 * width)),
        0, 0, width, COLUMNS,
    )
    head.write(0.0)
    calc.iterate(0, 0, 0)
    assert chain[-1]._rtcf_outputs["out"]._slot.value == 10.0
    assert looked_up == []
    assert [sys.getrefcount(p) for p in ports] == before
    # rewired after the plans were compiled: the slots the loop knew of are gone
    chain[3]._rtcf_inputs["in"]._connect(head)
    head.write(100.0)
    calc.iterate(1, 0, 0)
    assert chain[-1]._rtcf_outputs["out"]._slot.value == 107.0
    calc.release()


# ---- CommandCheck: a hardware command input's check (rtcf._core._command_limits) -------

NAN, INF = float("nan"), float("inf")


def _check(m: ModuleType, lo: Any, hi: Any, step: Any = None) -> tuple[Any, Any, Any]:
    """A CommandCheck of the module on fresh arrays; (check, last, changed)."""
    n = len(lo)
    last, changed = np.zeros(n), np.zeros(n, dtype=bool)
    step = np.full(n, INF) if step is None else np.array(step, dtype=float)
    c = m.CommandCheck(np.array(lo, dtype=float), np.array(hi, dtype=float), step, last,
                       changed)
    return c, last, changed


@pytest.mark.parametrize("m", MODULES)
def test_a_command_check_passes_clamps_and_refuses(m: ModuleType) -> None:
    check, last, changed = _check(m, [-1.0, 0.0, -INF], [1.0, 2.0, INF], [0.5, INF, INF])
    assert check.size == 3
    out = np.full(3, 7.0)
    assert check(np.array([0.5, 1.0, 1e300]), out, False) == 0  # passed unchanged
    assert last.tolist() == [0.5, 1.0, 1e300]
    # without the rate limit: into [lo, hi]
    assert check(np.array([3.0, -1.0, -5.0]), out, False) == 1
    assert out.tolist() == [1.0, 0.0, -5.0] and changed.tolist() == [True, True, False]
    assert last.tolist() == [1.0, 0.0, -5.0]
    # with it: within step of last (joint 0: [0.5, 1.0]), then within [lo, hi]
    assert check(np.array([-1.0, 0.5, 9.0]), out, True) == 1
    assert out.tolist() == [0.5, 0.5, 9.0] and changed.tolist() == [True, False, False]
    assert check(np.array([0.9, 0.5, 9.0]), out, True) == 0  # within both
    assert last.tolist() == [0.9, 0.5, 9.0]
    # not finite: refused, nothing written
    out[:] = 7.0
    changed[:] = True
    for value, code in (([NAN, 0.0, 0.0], 2), ([0.0, INF, 0.0], 3), ([NAN, 0.0, -INF], 3),
                        ([9.0, NAN, 0.0], 2)):
        assert check(np.array(value), out, True) == code
    assert last.tolist() == [0.9, 0.5, 9.0] and out.tolist() == [7.0] * 3
    assert changed.all()


@pytest.mark.parametrize("m", MODULES)
def test_a_command_check_calls_malformed_what_is_not_one_float64_per_joint(
    m: ModuleType,
) -> None:
    check, last, _ = _check(m, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
    out = np.zeros(3)
    for value in (np.zeros(3, dtype=np.float32), np.zeros(3, dtype=np.int64),
                  np.zeros(3, dtype=">f8"), np.zeros(3, dtype=bool), np.zeros(4), np.zeros(2),
                  np.zeros((3, 1)), np.zeros((1, 3)), np.float64(1.0), np.zeros(0),
                  [0.0, 0.0, 0.0], (0.0, 0.0, 0.0), None, 1.0, "abc", bytes(24),
                  array("f", [0.0] * 3), array("d", [0.0] * 4)):
        assert check(value, out, False) == 4, value  # no exception either
    assert last.tolist() == [0.0] * 3
    # any other float64 buffer of 3, any strides, read-only or not: checked as it is
    six = np.array([5.0, -9.0, 0.5, -9.0, -5.0, -9.0])
    assert check(six[::2], out, False) == 1  # a non-contiguous view: handled
    assert out.tolist() == [1.0, 0.5, -1.0]
    assert check(six[::-2], out, False) == 1
    assert out.tolist() == [-1.0, -1.0, -1.0]
    assert check(array("d", [0.25, 0.5, 0.75]), out, False) == 0
    assert last.tolist() == [0.25, 0.5, 0.75]
    frozen = np.array([0.1, 0.2, 0.3])
    frozen.flags.writeable = False
    assert check(memoryview(frozen), out, False) == 0
    unaligned = np.frombuffer(bytes(1) + np.array([0.5, 2.0, 0.0]).tobytes(), offset=1)
    assert check(unaligned, out, False) == 1 and out.tolist() == [0.5, 1.0, 0.0]


@pytest.mark.parametrize("m", MODULES)
def test_a_command_check_clamps_into_its_own_array_and_keeps_a_joint_bit_for_bit(
    m: ModuleType,
) -> None:
    check, _, changed = _check(m, [0.0, -1.0], [2.0, 1.0])
    out = np.zeros(2)
    value = np.array([-0.0, 5.0])  # -0.0 is within [0, 2]: it stays -0.0
    assert check(value, out, False) == 1
    assert out.tobytes() == np.array([-0.0, 1.0]).tobytes()
    assert changed.tolist() == [False, True]
    assert value.tolist() == [-0.0, 5.0]  # the writer's array is left alone
    inplace = np.array([3.0, 0.5])  # value and out one array: each joint read first
    assert check(inplace, inplace, False) == 1 and inplace.tolist() == [2.0, 0.5]


@pytest.mark.parametrize("m", MODULES)
def test_a_command_check_refuses_arrays_it_cannot_hold(m: ModuleType) -> None:
    n3, b3 = np.zeros(3), np.zeros(3, dtype=bool)
    frozen = np.zeros(3)
    frozen.flags.writeable = False
    for args in ((n3, n3, n3, n3, n3), (n3, np.zeros(2), n3, n3, b3),
                 (n3, n3, n3, np.zeros(3, dtype=np.float32), b3), (n3, n3, n3, frozen, b3),
                 (n3, n3, np.zeros(6)[::2], n3, b3)):
        with pytest.raises(TypeError, match="CommandCheck"):
            m.CommandCheck(*args)


def test_the_compiled_and_python_command_checks_agree_bit_for_bit() -> None:
    rng = np.random.default_rng(38)
    for n in (1, 2, 7, 30):
        lo = rng.uniform(-2.0, 0.0, n)
        hi = rng.uniform(0.0, 2.0, n)
        lo[rng.random(n) < 0.2] = -INF
        hi[rng.random(n) < 0.2] = INF
        step = rng.uniform(0.01, 1.0, n)
        step[rng.random(n) < 0.3] = INF
        checks = [_check(m, lo, hi, step) for m in (_compiled, _interpreted)]
        outs = [np.zeros(n), np.zeros(n)]
        codes = []
        for _ in range(2000):
            # near the last (passed on, as the common path), or anywhere (clamped)
            value = (checks[0][1] + rng.normal(0.0, 0.001, n) if rng.random() < 0.4
                     else rng.normal(0.0, 1.5, n))
            odd = rng.random()
            if odd < 0.05:
                value[rng.integers(n)] = NAN
            elif odd < 0.1:
                value[rng.integers(n)] = rng.choice([INF, -INF])
            has_last = bool(rng.random() < 0.7)
            got = []
            for (check, last, changed), out in zip(checks, outs, strict=True):
                code = check(value, out, has_last)
                got.append((code, last.tobytes(),
                            (out.tobytes(), changed.tobytes()) if code == 1 else None))
            assert got[0] == got[1]
            codes.append(got[0][0])
        assert {0, 1, 2, 3} <= set(codes), n


@pytest.mark.parametrize("m", MODULES)
def test_a_command_check_leaks_no_reference(m: ModuleType) -> None:
    lo, hi, step = np.full(4, -1.0), np.full(4, 1.0), np.full(4, 0.1)
    last, changed = np.zeros(4), np.zeros(4, dtype=bool)
    arrays = (lo, hi, step, last, changed)
    before_arrays = [sys.getrefcount(a) for a in arrays]
    check = m.CommandCheck(lo, hi, step, last, changed)
    good, far, nan, out = np.zeros(4), np.full(4, 5.0), np.full(4, NAN), np.zeros(4)
    wrong = np.zeros(3)
    values = (good, far, nan, wrong, out)
    before = [sys.getrefcount(v) for v in values]
    for k in range(20_000):
        check(good, out, k % 2 == 0)
        check(far, out, k % 2 == 0)
        check(nan, out, True)
        check(wrong, out, False)
        check(None, out, False)
    assert [sys.getrefcount(v) for v in values] == before
    del check
    gc.collect()
    assert [sys.getrefcount(a) for a in arrays] == before_arrays


def test_the_compiled_command_check_refuses_a_clamp_into_what_is_no_output() -> None:
    check, last, changed = _check(_compiled, [-1.0], [1.0])
    for out in (np.zeros(2), np.zeros(1, dtype=np.float32), None):
        with pytest.raises(TypeError):
            check(np.array([2.0]), out, False)
    assert last.tolist() == [0.0] and changed.tolist() == [False]
    assert check(np.array([0.5]), None, False) == 0  # out is only taken for a clamp
    with pytest.raises(TypeError, match="check"):
        check(np.array([0.5]), None)


def _in_loop_gate_trace(m: ModuleType) -> list[tuple[int, bool, int, int]]:
    """A deadline gate over an input whose value a component writes in the loop (after
    the gate's look) at iterations 0-2 and from 9, and which is fed before the look (as
    a feeder would) at 12: per iteration, whether the gate called fn, the due time, and
    the status the reader sees after the write."""
    out, inp = _ports(m)
    st = m.LoopState(100.0)
    out._state = st  # a write records the loop's iteration
    inp._deadline_ns = 25_000_000
    never = sys.maxsize
    seq, due = array("q", [0]), array("q", [never])
    called: list[int] = []
    gate: Any = None

    def fn() -> None:  # the watch in short: expire (keeping the seq), or clear
        called.append(st.iteration)
        s = inp._slot.seq
        if s != seq[0]:
            written_then = inp._slot.iteration == gate.last_iteration
            seq[0], inp._expired = s, 0
            due[0] = (gate.last_time_ns if written_then else st.time_ns) + 25_000_000
        elif st.time_ns > due[0]:
            inp._expired, due[0] = s, never

    gate = m.DeadlineGate(st, (inp,), seq, due, fn)
    assert gate.last_iteration == -2
    trace = []
    for i in range(14):
        st.iteration, st.time_ns = i, i * 10_000_000
        if i == 12:
            out.write(-1.0)  # before the look: a feeder's
        gate()
        assert (gate.last_iteration, gate.last_time_ns) == (i, st.time_ns)
        if i < 3 or 9 <= i < 12:
            out.write(float(i))  # in the loop, after the look
        trace.append((i, called[-1:] == [i], due[0], inp.status.value))
    return trace


def test_a_deadline_gate_counts_a_value_written_in_the_loop_from_the_iteration_that_wrote_it(
) -> None:
    compiled, python = _in_loop_gate_trace(_compiled), _in_loop_gate_trace(_interpreted)
    assert compiled == python  # side by side, iteration by iteration
    # written at 2 (20 ms): due 45 ms, past it at 5 (was: seen at 3, due 55 ms, past at 6)
    assert compiled[3][2] == 45_000_000 and [i for i, c, _, _ in compiled if c] == [5, 10]
    # (never read: NEW_DATA until EXPIRED) written again at 9, after the look: new data
    # at 9 (was: EXPIRED until the next look)
    assert [s for *_, s in compiled[4:11]] == [
        FlowStatus.NEW_DATA.value, *[FlowStatus.EXPIRED.value] * 4,
        FlowStatus.NEW_DATA.value, FlowStatus.NEW_DATA.value,
    ]
    # the return is taken at 10 as arriving at 9; the feeder's value at 12 arrives at 12
    assert compiled[10][2] == 115_000_000 and compiled[12][2] == 145_000_000
