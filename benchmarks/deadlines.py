"""What an input deadline costs per iteration, before and after its gate.

In-process on the simulated clock (no sleep: the loop's own work only): two components,
the second reading the first's output, best of 5 runs of 200,000 iterations, ns per
iteration. Three systems side by side in one run: no deadline; a deadline watched by
the full check in Python in every iteration (the watch before its gate); a deadline
watched by the loop's gate (rtcf._core._deadlines.DeadlineGate, which calls the full
check only when something changes). Both hot paths: the compiled one here, the Python
one in a child with ``RTCF_PURE_PYTHON=1``. Prints a table; writes nothing.

    .venv/bin/python benchmarks/deadlines.py [--iterations N] [--rounds N]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from typing import Any

from rtcf import Component, ComponentSpec
from rtcf._core import _deadlines, _hotpath
from rtcf._core._clock import SimClock
from rtcf._core._runner import Runner
from rtcf._core._settings import RunnerSettings

SYSTEMS = {
    "none": "no deadline",
    "every": "deadline, full check every iteration (before)",
    "gate": "deadline, the loop's gate (after)",
}


class Source(Component):
    def configure(self) -> None:
        self.out = self.add_output("x", float)

    def update(self) -> None:
        self.out.write(1.0)


class Sink(Component):
    deadline: float | None = 0.5

    def configure(self) -> None:
        self.inp = self.add_input("x", float, deadline=self.deadline)

    def update(self) -> None:
        self.inp.read()


class SinkNoDeadline(Sink):
    deadline = None


def _every_iteration(state: Any, ports: Any, seq: Any, due: Any, fn: Any) -> Any:
    return fn  # the watch's full check itself (a bound method: nothing to release)


def measure(system: str, iterations: int, rounds: int) -> float:
    """Best ns per iteration of ``rounds`` runs."""
    gate = _deadlines.DeadlineGate
    if system == "every":
        _deadlines.DeadlineGate = _every_iteration  # type: ignore[assignment,misc]
    runner = Runner(RunnerSettings(frequency=1000.0), clock=SimClock(), name="bench")
    try:
        runner.load(ComponentSpec("source", Source))
        runner.load(ComponentSpec("sink", SinkNoDeadline if system == "none" else Sink))
        best = float("inf")
        for n in [1000] + [iterations] * rounds:  # warm, then the rounds
            if system == "every":
                runner.deadlines.gate = None
            t0 = time.perf_counter_ns()
            runner.run(n)
            if n == iterations:
                best = min(best, (time.perf_counter_ns() - t0) / iterations)
        return best
    finally:
        runner.shutdown()
        _deadlines.DeadlineGate = gate  # type: ignore[misc]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=200_000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    here = {s: measure(s, args.iterations, args.rounds) for s in SYSTEMS}
    if args.child:
        print(json.dumps(here))
        return
    env = dict(os.environ, RTCF_PURE_PYTHON="1")
    child = subprocess.run(
        [sys.executable, __file__, "--child", f"--iterations={args.iterations}",
         f"--rounds={args.rounds}"], env=env, check=True, capture_output=True, text=True,
    )
    pure = json.loads(child.stdout.splitlines()[-1])
    print(f"ns per iteration, best of {args.rounds} x {args.iterations} (simulated clock)")
    print(f"| system | {_hotpath.describe().split(' ')[0]} | Python |")
    print("|---|---:|---:|")
    for system, label in SYSTEMS.items():
        print(f"| {label} | {here[system]:.0f} | {pure[system]:.0f} |")


if __name__ == "__main__":
    main()
