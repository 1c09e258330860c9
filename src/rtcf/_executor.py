"""The loop: a flat schedule of bound ``update`` methods run at a fixed rate.

Everything is resolved before the loop starts: the schedule is a tuple of bound
methods, timing rows go into a preallocated ring, and the loop itself does no
name look-up, no formatting and no I/O. ``idle`` (optional) runs after an
iteration has been recorded, outside the measured calculation time.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable, MutableSequence, Sequence
from dataclasses import dataclass

from ._clock import Clock
from ._loop_state import LoopState
from ._timing import COL_CALC, COL_ITERATION, COL_JITTER, COL_OVERRAN, COL_SCHEDULED, TimingWriter
from ._timing import FIXED_COLUMNS as F

STOP = 1  # end the loop: the user asked for it
CONTROL = 2  # end the loop: a control request (load, unload, ...) waits; the loop resumes after it


class StopFlag:
    """A word the loop reads once per iteration; non-zero ends it after the iteration.

    ``cell`` is any int64 sequence: an ``array`` in one process, or a word of a
    shared-memory segment the supervisor writes. Setting it is safe from a signal
    handler.
    """

    __slots__ = ("cell",)

    def __init__(self, cell: MutableSequence[int] | memoryview | None = None) -> None:
        self.cell: MutableSequence[int] | memoryview = cell if cell is not None else array("q", [0])

    @property
    def requested(self) -> bool:
        return self.cell[0] != 0

    @requested.setter
    def requested(self, value: bool) -> None:
        self.cell[0] = STOP if value else 0

    def set(self, reason: int = STOP) -> None:
        self.cell[0] = reason

    def clear(self) -> None:
        self.cell[0] = 0


@dataclass
class UpdateFailure(Exception):
    """A component's ``update`` raised; carries where and when."""

    index: int  # position in the schedule
    iteration: int
    time_ns: int
    error: BaseException


class Executor:
    """Runs ``updates`` in order, once per period of ``clock``."""

    def __init__(
        self,
        updates: Sequence[Callable[[], object]],
        clock: Clock,
        state: LoopState,
        timing: TimingWriter | None = None,
        *,
        wait_policy: str = "absolute",
        idle: Callable[[], object] | None = None,
        feeders: Sequence[Callable[[], object]] = (),
    ) -> None:
        self.updates = tuple(updates)
        self.clock = clock
        self.state = state
        self.timing = timing
        self.relative = wait_policy == "relative"
        self.idle = idle
        # run first in every iteration: copy the newest middleware messages into inputs
        self.feeders = tuple(feeders)
        self.origin_ns: int | None = None  # time of the very first scheduled start
        # where the next iteration is due; a later run() resumes on this grid
        self.next_deadline_ns: int | None = None

    def run(self, iterations: int | None, stop: StopFlag) -> int:
        """Run ``iterations`` iterations (None: until ``stop`` is set); return how many ran.

        Raises :class:`UpdateFailure` when an update raises.
        """
        timing = self.timing
        if timing is None or len(timing.components) != len(self.updates):
            raise RuntimeError("the executor has no timing writer for its schedule")
        clock = self.clock
        now = clock.now_ns
        sleep_until = clock.sleep_until_ns
        state = self.state
        indexed = tuple(enumerate(self.updates, F))  # column of each component's time
        reserve = timing.ring.reserve
        commit = timing.ring.commit
        words = timing.words
        scratch = timing.scratch
        cell = stop.cell
        period = state.period_ns
        relative = self.relative
        idle = self.idle
        feeders = self.feeders
        overruns = timing.overruns
        count = timing.count

        deadline = now()
        if self.next_deadline_ns is not None and self.next_deadline_ns > deadline:
            deadline = self.next_deadline_ns
        if self.origin_ns is None:
            self.origin_ns = deadline
        origin = self.origin_ns
        i = state.iteration + 1
        end = -1 if iterations is None else i + iterations
        first = i
        k = -1
        state.running = True
        try:
            while i != end and not cell[0]:
                off = reserve()  # before the sleep: not part of the measured times
                row: MutableSequence[int] | memoryview
                if off >= 0:
                    row, b = words, off >> 3
                else:  # ring full: the row goes to scratch; the ring counts the drop
                    row, b = scratch, 0
                sleep_until(deadline)
                t0 = now()
                state.iteration = i
                state.time_ns = deadline - origin
                t = t0
                if feeders:  # in the iteration's time, not in its first component's
                    for feed in feeders:
                        feed()
                    t = now()
                for k, update in indexed:
                    update()
                    t1 = now()
                    row[b + k] = t1 - t
                    t = t1
                k = -1
                row[b + COL_ITERATION] = i
                row[b + COL_SCHEDULED] = deadline
                row[b + COL_JITTER] = t0 - deadline
                row[b + COL_CALC] = t - t0
                deadline += period
                if t > deadline:
                    overruns += 1
                    row[b + COL_OVERRAN] = 1
                    if relative:
                        deadline = t + period
                else:
                    row[b + COL_OVERRAN] = 0
                if off >= 0:
                    commit()
                count += 1
                i += 1
                if idle is not None:
                    idle()
        except Exception as exc:
            if k < 0:
                raise
            deadline += period  # the failed iteration used its slot on the grid
            raise UpdateFailure(k - F, i, state.time_ns, exc) from exc
        finally:
            state.running = False
            self.next_deadline_ns = deadline
            timing.overruns = overruns
            timing.count = count
        return i - first
