"""The loop's hot path in Python: the same as ``_compiled*.c``, line for line (but for
the recording's word tap, which the Python path keeps in rtcf._runtime._recording).

It runs where the compiled module could not be built (no C compiler when rtcf was
installed) and with ``RTCF_PURE_PYTHON=1``; :mod:`rtcf._core._hotpath` picks one.
Both must keep exactly the same semantics: tests/unit/test_hotpath.py runs them
side by side.
"""

from __future__ import annotations

from collections.abc import Callable, MutableSequence
from typing import Any, Generic, TypeVar

import numpy as np

T = TypeVar("T")

_flow_status: list[Any] = [0, 1, 2, 3]


def set_flow_status(no_data: Any, old_data: Any, new_data: Any, expired: Any) -> None:
    """What a port's status returns (rtcf._core._ports.FlowStatus's members)."""
    _flow_status[:] = [no_data, old_data, new_data, expired]


class Slot:
    """The latest value on one topic and how many times it was written."""

    __slots__ = ("iteration", "seq", "value")

    def __init__(self) -> None:
        self.value: Any = None
        self.seq = 0  # number of writes; 0 means never written
        self.iteration = -1  # the loop iteration of the last write (-1: none, or outside)


class LoopState:
    """What the loop tells components about the current iteration."""

    __slots__ = ("frequency", "iteration", "period_ns", "running", "stamp_ns", "time_ns")

    def __init__(self, frequency: float = 1.0) -> None:
        if not frequency > 0:
            raise ValueError("LoopState: the frequency must be positive")
        self.frequency = float(frequency)
        self.period_ns = round(1e9 / frequency)
        self.iteration = -1  # -1 before the first iteration
        self.time_ns = 0  # scheduled start of the current iteration, since the loop started
        # the same instant in ROS time (ns since the epoch; /clock time under use_sim_time)
        self.stamp_ns = 0
        self.running = False


class _NoLoop:
    iteration = -1


_NO_LOOP = _NoLoop()


class Port(Generic[T]):
    """Common part of inputs and outputs."""

    __slots__ = (
        "_deadline_ns", "_expired", "_loop", "_seen", "_slot", "_tap", "component", "name",
        "topic", "type",
    )

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        self.component = component  # full name of the owning component
        self.name = name  # name given in add_input/add_output
        self.type = type_
        self.topic = ""  # resolved topic name, set when the runner wires the graph
        self._slot = Slot()
        self._loop: Any = _NO_LOOP  # the loop state a write reads (never None)
        self._seen = 0  # an input's: the slot's seq at its last read
        self._deadline_ns = 0  # an input's deadline (0: none); the loop's watch reads it
        # an input's: the slot's seq when the watch found it past its deadline (0: not
        # past it); a value written since is new data at once
        self._expired = 0
        # an output's: called with every written value while it is mapped or recorded
        self._tap: Callable[[Any], None] | None = None

    @property
    def qualified_name(self) -> str:
        return f"{self.component}.{self.name}"

    @property
    def _state(self) -> LoopState | None:
        state = self._loop
        return None if isinstance(state, _NoLoop) else state

    @_state.setter
    def _state(self, state: LoopState | None) -> None:
        self._loop = _NO_LOOP if state is None else state


class OutputPort(Port[T]):
    """An output port: ``write(value)`` makes ``value`` the topic's latest value."""

    __slots__ = ()
    direction = "output"

    def __init__(self, component: str, name: str, type_: type[T], state: Any = None) -> None:
        super().__init__(component, name, type_)
        # the loop's state: a write records its iteration (-1 for a port outside a loop)
        self._state = state

    def write(self, value: T) -> None:
        """Make value the topic's latest value."""
        slot = self._slot
        slot.value = value
        slot.seq += 1
        slot.iteration = self._loop.iteration
        tap = self._tap
        if tap is not None:  # mapped to the middleware or recorded: the tap too, after
            tap(value)

    def __repr__(self) -> str:
        return f"<OutputPort {self.qualified_name} -> {self.topic or '?'} [{self.type.__name__}]>"


class InputPort(Port[T]):
    """An input port: ``read()`` returns the latest value on its topic, or None."""

    __slots__ = ("producer",)
    direction = "input"

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        super().__init__(component, name, type_)
        self.producer: OutputPort[Any] | None = None

    def read(self) -> T | None:
        """Return the latest value (None before the first write) and mark it as seen."""
        slot = self._slot
        self._seen = slot.seq
        return slot.value

    @property
    def status(self) -> Any:
        """EXPIRED if the value is older than the port's deadline, else NEW_DATA if written
        since this port's last read, OLD_DATA if not, or NO_DATA."""
        seq = self._slot.seq
        if seq == 0:
            return _flow_status[0]
        if seq == self._expired:  # the value found too old is still the latest
            return _flow_status[3]
        return _flow_status[2] if seq != self._seen else _flow_status[1]

    @property
    def deadline(self) -> float | None:
        """The deadline in seconds (add_input(..., deadline=) or the launch file), or None."""
        return self._deadline_ns / 1e9 if self._deadline_ns > 0 else None

    @property
    def iteration(self) -> int:
        """The loop iteration in which the value on this topic was written: with
        components at several rates, which iteration's value a reader sees (-1 before
        the first write, and for values fed from the middleware)."""
        return int(self._slot.iteration)

    @property
    def has_new_data(self) -> bool:
        """True if the value was written since this port's last ``read()``."""
        return bool(self._slot.seq != self._seen)

    @property
    def connected(self) -> bool:
        """True if a producer inside the runner writes this input's topic."""
        return self.producer is not None

    def _connect(self, producer: OutputPort[Any] | None) -> None:
        """Share ``producer``'s slot, or get a fresh private one (no producer)."""
        slot = producer._slot if producer is not None else Slot()
        if producer is None and self.producer is None:
            slot = self._slot  # stays unconnected: keep what a bridge may have fed it
        if slot is not self._slot:
            self._slot = slot
            self._seen = 0
        self.producer = producer

    def __repr__(self) -> str:
        return f"<InputPort {self.qualified_name} <- {self.topic or '?'} [{self.type.__name__}]>"


SKIPPED = -1  # a component's time column in an iteration it did not run in
NO_LOOK = -2  # a DeadlineGate's last_iteration before its first look (no slot says -2)


class CompiledPlans:
    """An executor's plans as the calculation runs them, built where the executor builds
    its plans (``Executor.set_active``), so that the loop's first iteration after a
    change only takes them: the compiled path's arrays of what each update calls and
    what it will touch; here the plans themselves, checked the same way."""

    __slots__ = ("columns", "plans")

    def __init__(self, plans: Any) -> None:
        if not isinstance(plans, tuple) or not plans or not all(
            isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], tuple)
            and isinstance(p[1], tuple) and all(
                isinstance(s, tuple) and len(s) == 2 for s in p[0]
            )
            for p in plans
        ):
            raise TypeError(
                "Calculation: executor.plans must be a tuple of (steps, skipped) tuples"
            )
        columns = [k for steps, skipped in plans for k, _ in steps]
        columns += [k for _, skipped in plans for k in skipped]
        if any(k < 0 for k in columns):
            raise IndexError("Calculation: a plan's column outside the row")
        self.plans = plans
        self.columns = max(columns, default=-1) + 1  # how wide a timing row must be


class Calculation:
    """The timed part of the loop's iterations (see rtcf._core._executor)."""

    def __init__(
        self,
        executor: Any,
        state: LoopState,
        feeders: tuple[Callable[[], object], ...],
        now: Callable[[], int],
        sleep_until: Callable[[int], object],
        native_now: bool,
        native_sleep: bool,
        running: MutableSequence[int] | memoryview,
        words: MutableSequence[int] | memoryview,
        scratch: MutableSequence[int] | memoryview,
        origin: int,
        ros_offset: int,
        width: int,
        columns: tuple[int, int, int, int, int],
        ns_per_cycle: float = 0.0,  # (the compiled path's cycle counter; none here)
    ) -> None:
        self._executor = executor
        self._state = state
        self._feeders = feeders
        # (native_now, native_sleep: the clock reads CLOCK_MONOTONIC, and sleeps with
        # clock_nanosleep(TIMER_ABSTIME), which the compiled path calls itself; here
        # they are the same calls)
        self._now = now
        self._sleep_until = sleep_until
        self._running = running
        self._words = words
        self._scratch = scratch
        self._origin = origin
        self._ros_offset = ros_offset
        self._columns = columns

    def iterate(self, i: int, deadline: int, b: int) -> int:
        """Sleep until ``deadline``, then the timed part of iteration i; returns when it
        ended. An update that raises leaves its column in the running word."""
        self._sleep_until(deadline)
        now = self._now
        row: Any
        if b >= 0:
            row = self._words
        else:
            row, b = self._scratch, 0
        running = self._running
        t0 = now()
        state = self._state
        state.iteration = i
        state.time_ns = deadline - self._origin
        state.stamp_ns = deadline + self._ros_offset
        t = t0
        feeders = self._feeders
        if feeders:  # in the iteration's time, not in its first component's
            for feed in feeders:
                feed()
            t = now()
        # read after the feeders (a swap applies now); one plan per phase
        plans = self._executor.plans
        phase = i % len(plans)
        steps, skipped = plans[phase]
        for k, update in steps:
            running[0] = k
            update()
            t1 = now()
            row[b + k] = t1 - t
            t = t1
        running[0] = -1
        for c in skipped:
            row[b + c] = SKIPPED
        c_iteration, c_scheduled, c_jitter, c_calc, c_phase = self._columns
        row[b + c_iteration] = i
        row[b + c_scheduled] = deadline
        row[b + c_jitter] = t0 - deadline
        row[b + c_calc] = t - t0
        row[b + c_phase] = phase
        return t

    def release(self) -> None:
        """Let go of the running word, the ring and the scratch row."""
        self._running = self._words = self._scratch = None  # type: ignore[assignment]


class RingGate:
    """Call ``fn`` when ``words[head] != words[tail]`` (a ring with records waiting)."""

    def __init__(self, words: Any, head: int, tail: int, fn: Callable[[], object]) -> None:
        self._words = words
        self._head = head
        self._tail = tail
        self.fn = fn

    def __call__(self) -> object:
        words = self._words
        if words is None or words[self._head] == words[self._tail]:
            return None
        return self.fn()

    def release(self) -> None:
        """Let go of the ring's words (calls do nothing after)."""
        self._words = None


class HeartbeatWatch:
    """A feeder that ends the loop (``stop[0] = abort``) when ``cell[0]`` has not moved
    for ``limit`` iterations."""

    __slots__ = ("_abort", "_cell", "_stop", "fired", "last", "left", "limit")

    def __init__(self, cell: Any, limit: int, stop: Any, abort: int) -> None:
        if limit <= 0:
            raise ValueError("HeartbeatWatch: the limit must be positive")
        self._cell = cell
        self._stop = stop
        self._abort = abort
        self.last = cell[0]
        self.limit = self.left = limit
        self.fired = False

    def __call__(self) -> None:
        cell = self._cell
        if cell is None:
            return
        beat = cell[0]
        if beat != self.last:
            self.last = beat
            self.left = self.limit
            return
        self.left -= 1
        if self.left == 0:
            self.fired = True
            self._stop[0] = self._abort

    def release(self) -> None:
        """Let go of the two words (calls do nothing after)."""
        self._cell = self._stop = None


class DeadlineGate:
    """The loop's last feeder where inputs have deadlines: per port k, a new value sets
    ``seq[k]`` and ``due[k] = its arrival + its deadline``; calls ``fn`` (the watch's
    full check) when one past its deadline has a value again or ``time_ns > due[k]``.

    A value that came into the slot in the loop since the last look (a component's
    write, or a lane's handover: its slot's iteration is 0 to ``last_iteration``)
    arrived at the start of the last look's iteration (``last_time_ns``); one fed before
    this look (the middleware's: its slot's iteration is -1), at this one's."""

    __slots__ = ("_due", "_ports", "_seq", "_state", "fn", "last_iteration", "last_time_ns")

    def __init__(
        self, state: Any, ports: tuple[Any, ...], seq: Any, due: Any, fn: Callable[[], object]
    ) -> None:
        if len(seq) < len(ports) or len(due) < len(ports):
            raise IndexError("DeadlineGate: fewer words than ports")
        self._state = state
        self._ports = ports
        self._seq: Any = seq
        self._due = due
        self.fn = fn
        self.last_iteration = NO_LOOK  # the iteration of the last look
        self.last_time_ns = 0  # its start, on the loop's clock

    def __call__(self) -> object:
        seq = self._seq
        if seq is None:
            return None
        state = self._state
        i, t = state.iteration, state.time_ns
        due = self._due
        result = None
        k = 0  # (no enumerate: no tuple per input and iteration)
        for port in self._ports:
            slot = port._slot
            s = slot.seq
            if s != seq[k]:
                if port._expired:  # back: the watch's check takes it from here
                    result = self.fn()
                    break
                seq[k] = s
                w = slot.iteration  # in the slot since the last look's iteration began?
                arrival = self.last_time_ns if 0 <= w <= self.last_iteration else t
                due[k] = arrival + port._deadline_ns
            elif t > due[k]:
                result = self.fn()  # (it reads the last look's iteration and time)
                break
            k += 1
        self.last_iteration = i
        self.last_time_ns = t
        return result

    def release(self) -> None:
        """Let go of the words (calls do nothing after)."""
        self._seq = self._due = None


class CommandCheck:
    """A hardware command input's check (rtcf._core._command_limits.CommandGuard) in one
    call, on the guard's own arrays: ``lo``, ``hi``, ``step`` (per joint; inf where no
    rate limit) and ``last`` (the command last passed on, which each check that passes
    one on copies in), float64 of n; ``changed``, bool of n. ``lo`` and ``hi`` are fixed
    once given (whether they bound at all is read here once); ``step`` may change.

    ``check(value, out, has_last)``: ``value`` the new command, ``out`` the guard's array
    for a clamped one, ``has_last`` whether the rate limit applies (within ``step`` of
    ``last``). Returns 0: passed unchanged (last := value); 1: clamped into ``out``
    (last := out; ``changed`` says which joints; a joint within its bounds keeps its
    value bit for bit); 2: refused, a NaN and no infinity; 3: refused, an infinity; 4:
    malformed, not a 1-D float64 buffer of n (any strides: a view is checked as it is).
    ``changed`` is written only on 1, ``last`` only on 0 and 1; ``out`` holds the
    clamped command after 1, and is scratch here otherwise (C leaves it alone).

    With numpy's out= arrays: nothing allocated when ``value`` is a float64 ndarray."""

    __slots__ = ("_bounded", "_changed", "_hi", "_hi_now", "_last", "_lo",
                 "_lo_now", "_ok", "_scratch", "_shape", "_step", "size")

    def __init__(self, lo: Any, hi: Any, step: Any, last: Any, changed: Any) -> None:
        n = len(lo)
        for name, a, kind in (("lo", lo, "float64"), ("hi", hi, "float64"),
                              ("step", step, "float64"), ("last", last, "float64"),
                              ("changed", changed, "bool")):
            if (type(a) is not np.ndarray or a.dtype != np.dtype(kind) or a.shape != (n,)
                    or not a.flags.c_contiguous
                    or (name in ("last", "changed") and not a.flags.writeable)):
                raise TypeError(f"CommandCheck: {name} must be a 1-D {kind} array of {n}")
        self._lo, self._hi, self._step, self._last, self._changed = lo, hi, step, last, changed
        self.size = n
        self._shape = (n,)
        self._bounded = bool(np.isfinite(lo).any() or np.isfinite(hi).any())
        self._ok = np.zeros(n, dtype=bool)
        self._lo_now = np.zeros(n)
        self._hi_now = np.zeros(n)
        self._scratch = np.zeros(n)  # a clamp of out into itself

    def __call__(self, value: Any, out: Any, has_last: Any) -> int:
        if type(value) is not np.ndarray:  # another buffer: as numpy reads it, or 4
            try:
                view = memoryview(value)
            except TypeError:
                return 4
            if view.format not in _FLOAT64 or view.ndim != 1:
                return 4
            value = np.asarray(view)
        if value.shape != self._shape:
            return 4
        dtype = value.dtype
        if dtype is not _F64 and dtype != _F64:  # (a buffer's "<d" may be a new instance)
            return 4
        ok = self._ok
        np.isfinite(value, out=ok)
        n = self.size
        # count_nonzero, not ok.all(): a reduction allocates (about 900 B, past pymalloc)
        if np.count_nonzero(ok) != n:
            np.isinf(value, out=ok)
            return 3 if np.count_nonzero(ok) else 2
        if has_last or self._bounded:
            lo, hi = self._lo, self._hi
            if has_last:  # within a period's change of the last
                lo, hi, last = self._lo_now, self._hi_now, self._last
                np.subtract(last, self._step, out=lo)
                np.maximum(lo, self._lo, out=lo)
                np.add(last, self._step, out=hi)
                np.minimum(hi, self._hi, out=hi)
            work = out if value is not out else self._scratch  # (out: scratch unless 1)
            np.minimum(value, hi, out=work)
            np.maximum(work, lo, out=work)
            np.equal(work, value, out=ok)  # the joints left as they were
            if np.count_nonzero(ok) != n:
                np.copyto(work, value, where=ok)  # bit for bit (-0.0 stays -0.0)
                np.logical_not(ok, out=self._changed)
                if work is not out:
                    np.copyto(out, work)
                np.copyto(self._last, out)
                return 1
        np.copyto(self._last, value)
        return 0


_F64 = np.dtype(np.float64)  # native byte order
_FLOAT64 = ("d", "@d", "=d", "<d" if np.little_endian else ">d")


# A recorded float, int or bool output's tap that the port's write calls directly: only
# compiled (rtcf._core._compiled.WordTap). The Python path records through
# rtcf._runtime._recording's own taps, which push the same records.
WordTap = None

# A value crossing lanes (a send, a receive, a LET lane's output): only compiled
# (rtcf._core._compiled.Handover). The Python path hands over through
# rtcf._runtime._lanes's own classes, which do the same.
Handover = None
