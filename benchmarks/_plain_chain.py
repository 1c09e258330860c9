"""The reference for hot_path.py: a chain of trivial components as plain Python objects.

Run as its own process under the conditions rtcf's loop gets, as ``_plain_loop.py``
does: SCHED_FIFO, one CPU, mlockall, the garbage collector frozen and off, absolute
deadlines with ``clock_nanosleep(TIMER_ABSTIME)`` on CLOCK_MONOTONIC, and
``time.monotonic_ns`` (the clock rtcf reads) around the work. Prints one JSON object
with the samples' summary.

The work is rtcf_examples' Ramp and Gains without ports: a PlainRamp (``value +=
step``) and N-1 PlainGains (``value = src.value * gain``), each object's bound
``update`` called in order. ``--timed`` also reads the clock after every update and
stores the difference into a row, as rtcf's loop does per component: what per-component
timing costs in plain Python.

    python benchmarks/_plain_chain.py --frequency 500 --duration 10 --cpu 1 --priority 80
"""

from __future__ import annotations

import argparse
import gc
import time
from array import array
from collections.abc import Callable

from _plain_loop import CLOCK_MONOTONIC, TIMER_ABSTIME, print_result, realtime_setup


class PlainRamp:
    def __init__(self, step: float = 1.0) -> None:
        self.step = step
        self.value = 0.0

    def update(self) -> None:
        self.value += self.step


class PlainGain:
    def __init__(self, src: PlainRamp | PlainGain, gain: float = 1.0001) -> None:
        self.src = src
        self.gain = gain
        self.value = 0.0

    def update(self) -> None:
        self.value = self.src.value * self.gain


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frequency", type=float, default=500.0)
    p.add_argument("--duration", type=float, default=10.0)
    p.add_argument("--components", type=int, default=200)
    p.add_argument("--cpu", type=int, default=None)
    p.add_argument("--priority", type=int, default=80)
    p.add_argument("--timed", action="store_true", help="time every update into a row")
    args = p.parse_args()

    realtime, nanosleep, ts, ts_ptr = realtime_setup(args.cpu, args.priority)
    now = time.monotonic_ns

    chain: list[PlainRamp | PlainGain] = [PlainRamp()]
    for _ in range(args.components - 1):
        chain.append(PlainGain(chain[-1]))
    updates: tuple[Callable[[], None], ...] = tuple(o.update for o in chain)
    steps = tuple(enumerate(updates))
    row: array[int] = array("q", bytes(8 * len(updates)))  # the timing row, reused

    period = round(1e9 / args.frequency)
    n = max(1, round(args.duration * args.frequency))
    jitter: array[int] = array("q", bytes(8 * n))
    calc: array[int] = array("q", bytes(8 * n))
    overruns = 0
    timed = args.timed  # a local: the branch costs a few ns per iteration, not per component

    gc.collect()
    gc.freeze()
    gc.disable()
    deadline = now()
    for i in range(n):
        ts.tv_sec, ts.tv_nsec = divmod(deadline, 1_000_000_000)
        nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ts_ptr, None)
        t0 = now()
        if timed:
            t = t0
            for k, update in steps:
                update()
                t1 = now()
                row[k] = t1 - t
                t = t1
        else:
            for update in updates:
                update()
            t1 = now()
        jitter[i] = t0 - deadline
        calc[i] = t1 - t0
        deadline += period
        if t1 > deadline:
            overruns += 1
    gc.enable()
    print_result(args.frequency, n, overruns, realtime, jitter, calc, chain[-1].value,
                 components=len(updates), timed=args.timed)


if __name__ == "__main__":
    main()
