"""The reference for overhead.py: Fig. 1's sums in a plain hand-written Python loop.

Run as its own process under the conditions rtcf's loop gets: SCHED_FIFO, one CPU,
mlockall, the garbage collector frozen and off, absolute deadlines with
``clock_nanosleep(TIMER_ABSTIME)`` on CLOCK_MONOTONIC, and ``time.monotonic_ns`` (the
clock rtcf reads) around the work. Prints one JSON object with the samples' summary.

The work is Mimo's update (four inputs summed, unconnected inputs counting 0.0, two
outputs) for H1, F1, R1, R2, R3 with paper_evaluation.launch's wiring; H1 reads R3's
and R1's outputs of the previous iteration (its is_first breaks the loops).

    python benchmarks/_plain_loop.py --frequency 2000 --duration 30 --cpu 1 --priority 80
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import gc
import json
import math
import os
import time
from array import array
from typing import Any

CLOCK_MONOTONIC = time.CLOCK_MONOTONIC
TIMER_ABSTIME = 1
MCL_CURRENT, MCL_FUTURE = 1, 2


class Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


def summarize(values: array[int], n: int) -> dict[str, float]:
    """Nearest-rank quantiles in µs of the first ``n`` nanosecond samples."""
    s = sorted(values[:n])
    out = {"min": s[0] / 1e3}
    for key, q in (("p50", 0.5), ("p99", 0.99), ("p999", 0.999)):
        out[key] = s[max(1, math.ceil(q * n)) - 1] / 1e3
    out["max"] = s[-1] / 1e3
    out["mean"] = sum(s) / n / 1e3
    return out


def realtime_setup(cpu: int | None, priority: int) -> tuple[dict[str, object], Any, Timespec, Any]:
    """The conditions rtcf's loop gets: pinned to ``cpu``, SCHED_FIFO ``priority``,
    mlockall; and libc's clock_nanosleep with its timespec, which the caller's loop
    calls inline (a wrapper would add a Python call to each wake-up). Returns what was
    applied, clock_nanosleep, the timespec and a pointer to it."""
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    realtime: dict[str, object] = {"scheduler": "SCHED_OTHER", "priority": None}
    if cpu is not None:
        os.sched_setaffinity(0, {cpu})
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        realtime.update(scheduler="SCHED_FIFO", priority=priority)
    except PermissionError:
        pass
    realtime["mlockall"] = libc.mlockall(MCL_CURRENT | MCL_FUTURE) == 0
    realtime["cpu_affinity"] = sorted(os.sched_getaffinity(0))
    nanosleep = libc.clock_nanosleep
    nanosleep.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.POINTER(Timespec), ctypes.c_void_p]
    nanosleep.restype = ctypes.c_int
    ts = Timespec()
    return realtime, nanosleep, ts, ctypes.pointer(ts)


def print_result(frequency: float, n: int, overruns: int, realtime: dict[str, object],
                 jitter: array[int], calc: array[int], result: float, **more: object) -> None:
    """The loop's one JSON line (what run_reference reads), after the measured loop."""
    print(
        json.dumps(
            {
                "frequency_hz": frequency,
                **more,
                "iterations": n,
                "overruns": overruns,
                "realtime": realtime,
                "jitter_us": summarize(jitter, n),
                "calc_us": summarize(calc, n),
                "result": result,
            }
        )
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frequency", type=float, default=2000.0)
    p.add_argument("--duration", type=float, default=10.0)
    p.add_argument("--cpu", type=int, default=None)
    p.add_argument("--priority", type=int, default=80)
    args = p.parse_args()

    realtime, nanosleep, ts, ts_ptr = realtime_setup(args.cpu, args.priority)
    now = time.monotonic_ns

    period = round(1e9 / args.frequency)
    n = max(1, round(args.duration * args.frequency))
    jitter: array[int] = array("q", bytes(8 * n))
    calc: array[int] = array("q", bytes(8 * n))
    overruns = 0
    # outputs of the previous iteration (H1 reads R1 and R3 one iteration late)
    r1 = r3 = 0.0
    g2 = 0.0  # /G2_R2: a middleware topic, no producer in the loop: Mimo reads 0.0
    z = 0.0  # an input that is not remapped: no producer, counts as 0.0

    gc.collect()
    gc.freeze()
    gc.disable()
    deadline = now()
    for i in range(n):
        ts.tv_sec, ts.tv_nsec = divmod(deadline, 1_000_000_000)
        nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, ts_ptr, None)
        t0 = now()
        h1 = r3 + r1 + z + z  # H1: in1 /R3_G2H1, in2 /R1_H1R2
        f1 = h1 + z + z + z  # F1: in1 /H1_F1G1
        r1 = h1 + z + z + z  # R1: in1 /H1_R1R2
        r2 = f1 + h1 + r1 + g2  # R2: /F1_R2R3, /H1_R1R2, /R1_H1R2, /G2_R2
        r3 = f1 + r2 + z + z  # R3: /F1_R2R3, /R2_R3
        t1 = now()
        jitter[i] = t0 - deadline
        calc[i] = t1 - t0
        deadline += period
        if t1 > deadline:
            overruns += 1
    gc.enable()
    print_result(args.frequency, n, overruns, realtime, jitter, calc, r3)


if __name__ == "__main__":
    main()
