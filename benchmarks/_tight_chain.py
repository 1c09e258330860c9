"""hot_path.py's tight loops: the chain in this process, back to back with no sleep, so
that the caches stay warm: what the framework's calls cost, apart from what a loop
that sleeps between iterations pays to bring its working set back (the real-time rows).

Pinned to one CPU at SCHED_FIFO, garbage collector frozen and off; best of repeats.
Prints one JSON object: ns per component for plain objects, plain objects timed per
component, and rtcf (its Runner, the hot path RTCF_PURE_PYTHON selects; the recorded
calculation p50 / components). Two more split rtcf's cost in two, for where the
nanoseconds go: rtcf's components (ports) called by a bare Python ``for`` loop, and the
plain objects called by rtcf's own loop (its ``Calculation``: a call from C, the
component clock, the timing row, the running word; recorded calculation p50).

    python benchmarks/_tight_chain.py --cpu 1 --priority 80 [--components 200]
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import time
from array import array
from collections.abc import Callable

from _common import NoSleepClock, best_ns_per_iteration
from _plain_chain import PlainGain, PlainRamp


def _plain_in_rtcf_loop(updates: tuple[Callable[[], None], ...]) -> Callable[[int], float]:
    """The plain objects' updates run by rtcf's own loop (its Calculation, the hot path
    RTCF_PURE_PYTHON selects, each update timed by the clock rtcf would use): returns
    a function that runs ``iterations`` back to back and gives their calculation p50."""
    from rtcf._core import _hotpath
    from rtcf._core._timing import CALCULATION_COLUMNS, COL_CALC, FIXED_COLUMNS

    class Plans:  # what the Calculation reads of an executor
        plans = ((tuple((FIXED_COLUMNS + k, u) for k, u in enumerate(updates)), ()),)

    width = FIXED_COLUMNS + len(updates)
    words = array("q", bytes(8 * width))
    calculation = _hotpath.Calculation(
        Plans(), _hotpath.LoopState(500.0), (), time.monotonic_ns, lambda d: None, True, False,
        array("q", [-1]), words, array("q", bytes(8 * width)), 0, 0, width,
        CALCULATION_COLUMNS, _hotpath.component_clock()[1],
    )

    def run(iterations: int) -> float:
        calc = array("q", bytes(8 * iterations))
        iterate = calculation.iterate
        for i in range(iterations):
            iterate(i, 0, 0)  # a deadline long past: no sleep
            calc[i] = words[COL_CALC]
        return float(sorted(calc)[iterations // 2])

    return run


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--components", type=int, default=200)
    p.add_argument("--iterations", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--cpu", type=int, default=None)
    p.add_argument("--priority", type=int, default=80)
    args = p.parse_args()
    if args.cpu is not None:
        os.sched_setaffinity(0, {args.cpu})
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.priority))
    except PermissionError:
        pass
    import rtcf
    from rtcf._core import _hotpath
    from rtcf_examples import Gain, Ramp

    n = args.components
    objs: list[PlainRamp | PlainGain] = [PlainRamp()]
    for _ in range(n - 1):
        objs.append(PlainGain(objs[-1]))
    updates = tuple(o.update for o in objs)
    row = array("q", bytes(8 * n))

    def plain(iterations: int) -> None:
        for _ in range(iterations):
            for u in updates:
                u()

    def plain_timed(iterations: int) -> None:
        now = time.monotonic_ns
        for _ in range(iterations):
            t = now()
            for k, u in enumerate(updates):
                u()
                t1 = now()
                row[k] = t1 - t
                t = t1

    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=500.0), clock=NoSleepClock(),
                         log_level="warning")
    runner.load(rtcf.ComponentSpec("c0", cls=Ramp, remaps={"out": "/t0"}))
    for k in range(1, n):
        runner.load(rtcf.ComponentSpec(f"c{k}", cls=Gain,
                                       remaps={"in_port": f"/t{k - 1}", "out_port": f"/t{k}"}))
    runner.run(100)  # start hooks, compile, warm
    components = tuple(runner.components[name].update for name in runner.order)

    def rtcf_components_bare(iterations: int) -> None:
        for _ in range(iterations):
            for u in components:
                u()

    plain_in_loop = _plain_in_rtcf_loop(updates)
    gc.collect()
    gc.freeze()
    gc.disable()
    iters = args.iterations
    out = {
        "hot_path": _hotpath.HOT_PATH,
        "component_clock": _hotpath.component_clock()[0],
        "plain": best_ns_per_iteration(plain, iters, args.repeats) / n,
        "plain_timed": best_ns_per_iteration(plain_timed, iters, args.repeats) / n,
        # the loop's own measure: the calculation's p50 (per-component timing included)
        "rtcf": min(
            runner.run(iters, drain_logs_every_iteration=False).timing.calc_us["p50"]
            for _ in range(args.repeats)
        ) * 1e3 / n,
        "rtcf_components_bare": best_ns_per_iteration(rtcf_components_bare, iters, args.repeats)
        / n,
        "plain_in_rtcf_loop": min(plain_in_loop(iters) for _ in range(args.repeats)) / n,
    }
    runner.shutdown()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
