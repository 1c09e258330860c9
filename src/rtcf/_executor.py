"""The loop: a flat schedule of bound ``update`` methods run at a fixed rate.

Everything is resolved before the loop starts: the schedule is a tuple of bound
methods, timing goes into preallocated arrays, and the loop itself does no name
look-up, no formatting and no I/O. ``idle`` (optional) runs after an iteration has
been recorded, outside the measured calculation time.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ._clock import Clock
from ._loop_state import LoopState
from ._timing import TimingRecorder


class StopFlag:
    """Set from a signal handler or another hook to end the loop after an iteration."""

    __slots__ = ("requested",)

    def __init__(self) -> None:
        self.requested = False

    def set(self) -> None:
        self.requested = True


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
        recorder: TimingRecorder,
        *,
        wait_policy: str = "absolute",
        idle: Callable[[], object] | None = None,
    ) -> None:
        self.updates = tuple(updates)
        self.clock = clock
        self.state = state
        self.recorder = recorder
        self.relative = wait_policy == "relative"
        self.idle = idle
        self.origin_ns: int | None = None  # time of the very first scheduled start
        # where the next iteration is due; a later run() resumes on this grid
        self.next_deadline_ns: int | None = None

    def run(self, iterations: int | None, stop: StopFlag) -> int:
        """Run ``iterations`` iterations (None: until ``stop`` is set); return how many ran.

        Raises :class:`UpdateFailure` when an update raises.
        """
        clock = self.clock
        now = clock.now_ns
        sleep_until = clock.sleep_until_ns
        state = self.state
        updates = self.updates
        indexed = tuple(enumerate(updates))
        rec = self.recorder
        mask = rec.mask
        jitter, calc, per = rec.jitter, rec.calc, rec.per_component
        ncomp = len(updates)
        period = state.period_ns
        relative = self.relative
        idle = self.idle

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
            while i != end and not stop.requested:
                sleep_until(deadline)
                t0 = now()
                state.iteration = i
                state.time_ns = deadline - origin
                t = t0
                slot = rec.count & mask  # by samples recorded, so a new recorder starts at 0
                base = slot * ncomp
                for k, update in indexed:
                    update()
                    t1 = now()
                    per[base + k] = t1 - t
                    t = t1
                k = -1
                jitter[slot] = t0 - deadline
                calc[slot] = t - t0
                rec.count += 1
                deadline += period
                if t > deadline:
                    rec.overruns += 1
                    if relative:
                        deadline = t + period
                i += 1
                if idle is not None:
                    idle()
        except Exception as exc:
            if k < 0:
                raise
            deadline += period  # the failed iteration used its slot on the grid
            raise UpdateFailure(k, i, state.time_ns, exc) from exc
        finally:
            state.running = False
            self.next_deadline_ns = deadline
        return i - first
