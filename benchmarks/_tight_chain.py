"""hot_path.py's tight loops: the chain in this process, back to back with no sleep, so
that the caches stay warm: what the framework's calls cost, apart from what a loop
that sleeps between iterations pays to bring its working set back (the real-time rows).

Pinned to one CPU at SCHED_FIFO, garbage collector frozen and off; best of repeats.
Prints one JSON object: ns per component for plain objects, plain objects timed per
component, and rtcf (its Runner, the hot path RTCF_PURE_PYTHON selects; the recorded
calculation p50 / components).

    python benchmarks/_tight_chain.py --cpu 1 --priority 80 [--components 200]
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import time
from array import array

from _common import NoSleepClock, best_ns_per_iteration
from _plain_chain import PlainGain, PlainRamp


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
    }
    runner.shutdown()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
