"""The loop's hot path in Python: the same as ``_compiled.c``, line for line (but for
the recording's word tap, which the Python path keeps in rtcf._runtime._recording).

It runs where the compiled module could not be built (no C compiler when rtcf was
installed) and with ``RTCF_PURE_PYTHON=1``; :mod:`rtcf._core._hotpath` picks one.
Both must keep exactly the same semantics: tests/unit/test_hotpath.py runs them
side by side.
"""

from __future__ import annotations

from collections.abc import Callable, MutableSequence
from typing import Any

_flow_status: list[Any] = [0, 1, 2]


def set_flow_status(no_data: Any, old_data: Any, new_data: Any) -> None:
    """What a port's status returns (rtcf._core._ports.FlowStatus's members)."""
    _flow_status[:] = [no_data, old_data, new_data]


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


class PortCore:
    """The base of rtcf's ports: a slot, the loop's state, what a reader last saw."""

    __slots__ = ("__state", "_seen", "_slot", "_tap")
    _slot: Slot
    _seen: int
    _tap: Callable[[Any], None] | None

    def __new__(cls, *args: Any, **kwargs: Any) -> Any:
        # as the compiled type's tp_new: every port has a slot before its __init__
        self = super().__new__(cls)
        self._slot = Slot()
        self.__state = _NO_LOOP
        self._seen = 0
        self._tap = None
        return self

    @property
    def _state(self) -> LoopState | None:
        state = self.__state
        return None if isinstance(state, _NoLoop) else state

    @_state.setter
    def _state(self, state: LoopState | None) -> None:
        self.__state = _NO_LOOP if state is None else state

    def _write(self, value: Any) -> None:
        """Make value the topic's latest value."""
        slot = self._slot
        slot.value = value
        slot.seq += 1
        slot.iteration = self.__state.iteration

    def _write_tapped(self, value: Any) -> None:
        """Make value the topic's latest value, and hand it to the tap."""
        slot = self._slot
        slot.value = value
        slot.seq += 1
        slot.iteration = self.__state.iteration
        tap = self._tap
        if tap is not None:
            tap(value)

    def _read(self) -> Any:
        """Return the latest value (None before the first write) and mark it as seen."""
        slot = self._slot
        self._seen = slot.seq
        return slot.value

    @property
    def _status(self) -> Any:
        """NEW_DATA if written since this port's last read, OLD_DATA if not, or NO_DATA."""
        seq = self._slot.seq
        if seq == 0:
            return _flow_status[0]
        return _flow_status[2] if seq != self._seen else _flow_status[1]

    @property
    def _has_new_data(self) -> bool:
        """True if the value was written since this port's last read()."""
        return bool(self._slot.seq != self._seen)

    @property
    def _iteration(self) -> int:
        """The loop iteration in which the value on this topic was written (-1 before
        the first write, and for values fed from the middleware)."""
        return int(self._slot.iteration)


SKIPPED = -1  # a component's time column in an iteration it did not run in


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


# A recorded float, int or bool output's tap that the port's write calls directly: only
# compiled (rtcf._core._compiled.WordTap). The Python path records through
# rtcf._runtime._recording's own taps, which push the same records.
WordTap = None
