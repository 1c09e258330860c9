"""The loop: a flat schedule of bound ``update`` methods run at a fixed rate.

Everything is resolved before the loop starts: the schedule is a tuple of bound
methods, timing rows go into a preallocated ring, and the loop itself does no
name look-up, no formatting and no I/O. ``idle`` (optional) runs after an
iteration has been recorded, outside the measured calculation time.

What an iteration runs is a :class:`Plan`, compiled from the schedule and the set of
active components. Changing that set (a lifecycle transition, later a fault policy
that takes a component and its downstream out) compiles a new plan and swaps it in
between two iterations: the loop reads ``executor.plan`` once per iteration, after
the feeders (which is where a transition that arrived from the supervisor is
applied), and has no per-component test. Components at several rates
(:mod:`rtcf._core._rates`) give one plan per phase of the hyperperiod: iteration
``i`` runs ``plans[i % len(plans)]``, one index, and the timing row says which.
"""

from __future__ import annotations

import math
import sys
import time
from array import array
from collections.abc import Callable, MutableSequence, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from ._clock import Clock
from ._faults import WatchdogTripped
from ._hotpath import Calculation, CompiledPlans, component_clock
from ._interpreted import SKIPPED as SKIPPED  # a component's column when it did not run
from ._loop_state import LoopState
from ._timing import (
    CALCULATION_COLUMNS,
    COL_ITERATION,
    COL_OVERRAN,
    TimingWriter,
)
from ._timing import FIXED_COLUMNS as F

STOP = 1  # end the loop: the user asked for it
CONTROL = 2  # end the loop: a control request (load, unload, ...) waits; the loop resumes after it
ABORT = 3  # end the loop abnormally (a signal, a lost supervisor): safe_stop hooks run


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




class Plan(NamedTuple):
    """What one iteration runs: ``(timing column, bound update)`` pairs in order, and the
    timing columns of scheduled components that do not run (they get ``SKIPPED``)."""

    steps: tuple[tuple[int, Callable[[], object]], ...]
    skipped: tuple[int, ...]


def hyperperiod(rates: Sequence[tuple[int, int]]) -> int:
    """Iterations after which a schedule of (every, phase) rates repeats: their lcm."""
    h = 1
    for every, _ in rates:
        h = h * every // math.gcd(h, every)
    return h


def compile_plans(
    updates: Sequence[Callable[[], object]],
    active: Sequence[bool],
    rates: Sequence[tuple[int, int]] | None = None,
    always: Sequence[bool] | None = None,
) -> tuple[Plan, ...]:
    """One plan per phase of the hyperperiod: iteration ``i`` runs plan ``i % len``.

    ``rates[k]`` is ``(every, phase)``: update ``k`` runs in iterations where
    ``(i - phase) % every == 0`` (every iteration when there are no rates).
    ``always[k]`` makes step ``k`` run in every iteration whatever its active flag and
    rate: a lane's handover of a value to another lane, which must happen in every
    iteration even when the component it follows is skipped.
    """
    if always is not None:
        if len(always) != len(updates):
            raise ValueError(f"{len(always)} always flags for a schedule of {len(updates)}")
        active = [a or w for a, w in zip(active, always, strict=True)]
    if rates is None or all(every == 1 for every, _ in rates):
        return (compile_plan(updates, active),)
    if len(rates) != len(updates):
        raise ValueError(f"{len(rates)} rates for a schedule of {len(updates)}")
    pinned = always or [False] * len(updates)
    tests = [lambda p, e=every, f=phase: (p - f) % e == 0 for every, phase in rates]
    return tuple(
        compile_plan(
            updates,
            [a and (w or runs(p)) for a, w, runs in zip(active, pinned, tests, strict=True)],
        )
        for p in range(hyperperiod(rates))
    )


def compile_plan(updates: Sequence[Callable[[], object]], active: Sequence[bool]) -> Plan:
    """The plan that runs ``updates[k]`` where ``active[k]``, keeping every column."""
    if len(active) != len(updates):
        raise ValueError(f"{len(active)} active flags for a schedule of {len(updates)}")
    steps = tuple((F + k, u) for k, u in enumerate(updates) if active[k])
    skipped = tuple(F + k for k in range(len(updates)) if not active[k])
    return Plan(steps, skipped)


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
        self.plan: Plan  # what each iteration runs; swapped between iterations by set_active()
        # per phase of the hyperperiod (several rates); iteration i runs plans[i % len]
        self.plans: tuple[Plan, ...] = ()
        # the plans as the loop's calculation runs them, compiled with them (set_active)
        self.compiled_plans: CompiledPlans
        self.hyperperiod = 1  # len(plans)
        self.rates: tuple[tuple[int, int], ...] | None = None  # (every, phase) per update
        # steps that run in every iteration, active or not (a lane's handovers)
        self.always: tuple[bool, ...] | None = None
        # a lane on logical execution time runs every ``stride`` iterations of the loop
        # (its iterations count in the loop's numbers), and after an overrun skips the
        # releases it missed, on the loop's grid, rather than running them late
        self.stride = 1
        self.skip_missed = False
        self.missed = 0  # releases skipped that way
        self.max_let_overruns = 0  # such a lane's watchdog: windows overrun in a run
        self.updates = updates  # all active
        self.clock = clock
        self.state = state
        self.timing = timing
        self.relative = wait_policy == "relative"
        self.idle = idle
        # run first in every iteration: copy the newest middleware messages into inputs
        self.feeders = tuple(feeders)
        # ROS time minus this clock's, for the stamps; None: the clock's own, read at
        # the start of each run
        self.ros_offset_ns: int | None = None
        self.origin_ns: int | None = None  # time of the very first scheduled start
        # where the next iteration is due; a later run() resumes on this grid
        self.next_deadline_ns: int | None = None
        # the timing column of the component whose update runs now (-1: none); a
        # worker's is a shared-memory word, so a supervisor can name it if the worker dies
        self.running: MutableSequence[int] | memoryview = array("q", [-1])
        # watchdogs (0: off): the loop ends past this many overruns in a row, or
        # within one second (frequency iterations from the first overrun counted)
        self.max_consecutive_overruns = 0
        self.max_overruns_per_second = 0

    @property
    def updates(self) -> tuple[Callable[[], object], ...]:
        """The schedule: every component's update in order, one timing column each."""
        return self._updates

    @updates.setter
    def updates(self, updates: Sequence[Callable[[], object]]) -> None:
        self._updates = tuple(updates)
        self.rates = None
        self.always = None
        self.set_active([True] * len(self._updates))

    def set_active(self, active: Sequence[bool]) -> None:
        """Run only the updates whose flag is true, from the next iteration on.

        Call it between iterations (a feeder, ``idle``) or between runs. It compiles a
        new plan (allocation, outside the loop's steady state) and swaps it in.
        Compiled here for the loop's calculation too (the compiled path's arrays and
        what to prefetch), so that the next iteration only takes them: nothing
        allocates in the first iteration after a lifecycle change or a fallback swap.
        """
        plans = compile_plans(self.updates, active, self.rates, self.always)
        self.hyperperiod = len(plans)  # the loop picks plans[i % hyperperiod]
        self.compiled_plans = CompiledPlans(plans)  # before plans: the loop reads plans first
        self.plans = plans
        self.plan = plans[0]

    def set_rates(
        self,
        rates: Sequence[tuple[int, int]],
        active: Sequence[bool],
        always: Sequence[bool] | None = None,
    ) -> None:
        """Run update ``k`` every ``rates[k][0]`` iterations from phase ``rates[k][1]``;
        where ``always[k]``, in every iteration whatever its rate and active flag."""
        self.rates = tuple(rates)
        self.always = tuple(always) if always is not None else None
        self.set_active(active)

    def run(self, iterations: int | None, stop: StopFlag) -> int:
        """Run ``iterations`` iterations (None: until ``stop`` is set); return how many ran.

        Raises :class:`UpdateFailure` when an update raises (any ``BaseException``),
        and :class:`WatchdogTripped` after the iteration in which a watchdog fired.
        """
        timing = self.timing
        if timing is None or len(timing.components) != len(self.updates):
            raise RuntimeError("the executor has no timing writer for its schedule")
        clock = self.clock
        now = clock.now_ns
        sleep_until = clock.sleep_until_ns
        state = self.state
        reserve = timing.ring.reserve
        commit = timing.ring.commit
        words = timing.words
        scratch = timing.scratch
        cell = stop.cell
        stride = self.stride
        period = state.period_ns * stride
        relative = self.relative
        skip_missed = self.skip_missed
        idle = self.idle
        feeders = self.feeders
        overruns = timing.overruns
        count = timing.count
        running = self.running
        max_streak = self.max_consecutive_overruns or sys.maxsize
        max_in_window = self.max_overruns_per_second or sys.maxsize
        # a lane on logical execution time (it skips missed releases) overran a window
        max_let = self.max_let_overruns if skip_missed and self.max_let_overruns else sys.maxsize
        let_overruns = 0
        window = max(1, round(state.frequency))
        streak = in_window = window_end = 0
        # ROS time of an iteration = its scheduled start + this (0 for simulated and
        # /clock time, whose clocks already count in it)
        ros_offset = self.ros_offset_ns
        if ros_offset is None:
            offset_of = getattr(clock, "ros_time_offset_ns", None)
            ros_offset = offset_of() if offset_of is not None else 0

        deadline = now()
        if self.next_deadline_ns is not None and self.next_deadline_ns > deadline:
            deadline = self.next_deadline_ns
        origin = self.origin_ns
        fresh = origin is None
        if origin is None:
            origin = self.origin_ns = deadline
        i = state.iteration + stride
        end = sys.maxsize if iterations is None else i + iterations
        first = i
        # the sleep and the timed part of each iteration (wake-up, loop state, feeders,
        # the plan's updates and their times, the running word): the hot path,
        # compiled where rtcf could build it
        # native: CLOCK_MONOTONIC, and absolute sleeps on it, which the compiled path
        # calls itself (no Python between the wake-up and the iteration's first time read)
        native_now = now is time.monotonic_ns
        native_sleep = native_now and bool(getattr(clock, "uses_clock_nanosleep", False))
        calculation = Calculation(
            self, state, feeders, now, sleep_until, native_now, native_sleep, running, words,
            scratch, origin, ros_offset, timing.width,
            CALCULATION_COLUMNS,
            component_clock()[1] if native_now else 0.0,
        )
        iterate = calculation.iterate
        running[0] = -1
        state.running = True
        try:
            while i < end and not cell[0]:
                off = reserve()  # before the sleep: not part of the measured times
                row: MutableSequence[int] | memoryview
                if off >= 0:
                    row, b = words, off >> 3
                else:  # ring full: the row goes to scratch; the ring counts the drop
                    row, b = scratch, 0
                t = iterate(i, deadline, b if off >= 0 else -1)  # sleeps first
                deadline += period
                if t > deadline:
                    overruns += 1
                    row[b + COL_OVERRAN] = 1
                    if relative:
                        deadline = t + period
                    elif skip_missed and t > deadline:  # the next release is due already
                        missed = (t - deadline) // period + 1
                        deadline += missed * period
                        i += missed * stride
                        self.missed += missed
                    let_overruns += 1
                    if let_overruns > max_let:
                        if off >= 0:
                            commit()
                        count += 1
                        raise WatchdogTripped(
                            "max_let_overruns", max_let, let_overruns, row[b + COL_ITERATION],
                            resume=i,
                        )
                    streak += 1
                    if i >= window_end:
                        window_end = i + window
                        in_window = 0
                    in_window += 1
                    if streak > max_streak or in_window > max_in_window:
                        if off >= 0:
                            commit()
                        count += 1
                        if streak > max_streak:
                            raise WatchdogTripped(
                                "max_consecutive_overruns", max_streak, streak, i
                            )
                        raise WatchdogTripped(
                            "max_overruns_per_second", max_in_window, in_window, i
                        )
                else:
                    streak = 0
                    row[b + COL_OVERRAN] = 0
                if off >= 0:
                    commit()
                count += 1
                i += stride
                if idle is not None:
                    idle()
        except BaseException as exc:  # SystemExit and KeyboardInterrupt are named too
            k = running[0]  # the update that raised leaves its column there
            if k < 0:
                raise
            running[0] = -1
            deadline += period  # the failed iteration used its slot on the grid
            raise UpdateFailure(k - F, i, state.time_ns, exc) from exc
        finally:
            calculation.release()
            state.running = False
            if fresh and state.iteration < first:
                # stopped before its first iteration (a load while waiting for the first
                # /clock): the loop has not started, so its time 0 is still to come
                self.origin_ns = None
            else:
                self.next_deadline_ns = deadline
            timing.overruns = overruns
            timing.count = count
        return i - first
