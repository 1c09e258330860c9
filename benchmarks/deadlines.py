"""What an input deadline costs per iteration, before and after its gate.

In-process on the simulated clock (no sleep: the loop's own work only): two components,
the second reading the first's output, best of 5 runs of 200,000 iterations (in
alternating rounds), ns per iteration. Three systems side by side in one run: no
deadline; a deadline watched by the full check in Python in every iteration (the watch
before its gate); a deadline watched by the loop's gate
(rtcf._core._deadlines.DeadlineGate, which calls the full check only when something
changes). Both hot paths: the compiled one here, the Python one in a child with
``RTCF_PURE_PYTHON=1``. Prints a table; writes nothing.

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
# the per-iteration look alone, called in a Python for loop (the loop itself included)
LOOKS = {
    "look_every": "the look alone: the full check (before)",
    "look_gate": "the look alone: the gate (after)",
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


class _EveryIteration:
    """The watch's full check in every iteration, keeping the last look's iteration and
    time as a gate does (the check reads them: a value written in the loop arrived
    then). The wrapper's own call is in the "before" rows (about 40 ns in Python)."""

    __slots__ = ("fn", "last_iteration", "last_time_ns", "state")

    def __init__(self, state: Any, ports: Any, seq: Any, due: Any, fn: Any) -> None:
        self.state, self.fn = state, fn
        self.last_iteration, self.last_time_ns = -2, 0

    def __call__(self) -> None:
        self.fn()
        state = self.state
        self.last_iteration, self.last_time_ns = state.iteration, state.time_ns

    def release(self) -> None:
        pass


def _run(system: str, runner: Runner, n: int) -> float:
    """ns per iteration of one run of n iterations."""
    gate = _deadlines.DeadlineGate
    if system == "every":
        _deadlines.DeadlineGate = _EveryIteration  # type: ignore[assignment,misc]
        runner.deadlines.gate = None
    try:
        t0 = time.perf_counter_ns()
        runner.run(n)
        return (time.perf_counter_ns() - t0) / n
    finally:
        _deadlines.DeadlineGate = gate  # type: ignore[misc]


def measure(iterations: int, rounds: int) -> dict[str, float]:
    """Per system, the best ns per iteration of ``rounds`` runs (alternating: each
    round runs every system once, so that a busy moment of the machine hits all)."""
    runners = {}
    for system in SYSTEMS:
        runner = Runner(RunnerSettings(frequency=1000.0), clock=SimClock(), name=system)
        runner.load(ComponentSpec("source", Source))
        runner.load(ComponentSpec("sink", SinkNoDeadline if system == "none" else Sink))
        _run(system, runner, 1000)  # warm
        runners[system] = runner
    best = dict.fromkeys([*SYSTEMS, *LOOKS], float("inf"))
    watch = runners["gate"].deadlines
    looks = {"look_every": watch.check, "look_gate": watch.gate}
    try:
        for _ in range(rounds):
            for system, runner in runners.items():
                best[system] = min(best[system], _run(system, runner, iterations))
            for look, call in looks.items():  # in the steady state: nothing changes
                t0 = time.perf_counter_ns()
                for _ in range(iterations):
                    call()
                best[look] = min(best[look], (time.perf_counter_ns() - t0) / iterations)
    finally:
        for runner in runners.values():
            runner.shutdown()
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=200_000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    here = measure(args.iterations, args.rounds)
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
    for system, label in {**SYSTEMS, **LOOKS}.items():
        print(f"| {label} | {here[system]:.0f} | {pure[system]:.0f} |")


if __name__ == "__main__":
    main()
