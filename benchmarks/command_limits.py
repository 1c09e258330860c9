"""What the limits at the hardware's edge cost per iteration: per command port and joint.

In-process on the simulated clock (no sleep: the loop's own work only): a writer
component writes a fresh float64 array per command port in every iteration and a
hardware component reads each one. Five systems side by side in one run, each with 1
and with 4 command ports on the one hardware and with 1, 7 and 30 joints per port, best
of 5 runs of 20,000 iterations (alternating rounds: each round runs every runner once),
ns per iteration:

* ``plain``: ``add_input`` (no check);
* ``finite``: ``add_command_input`` with no limits (the finite check only);
* ``effort``: with ``max_effort`` (the clamp path, the values within the limits);
* ``position``: with ``min_position``/``max_position`` and ``max_velocity`` (the rate
  limit too, the values within both);
* ``clamped``: as ``position``, the values above ``max_position`` in every iteration
  (clamped each time, counted, and logged once a simulated second: the worst case).

The difference to ``plain`` is the guards' cost; a least-squares fit of it as
``ports * (per_port + per_joint * joints)`` splits it into a cost per command port and
one per joint of a port. Both hot paths: the compiled one here, the Python one in a
child with ``RTCF_PURE_PYTHON=1`` (after this one: never both at once). Writes
``results/command_limits.json`` and its section of docs/performance.md.

    .venv/bin/python benchmarks/command_limits.py [--iterations N] [--rounds N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from typing import Any

import numpy as np
from _common import (
    BenchmarkError,
    fmt,
    machine_info,
    main_guard,
    now_iso,
    publish_section,
    table,
    write_results,
)

from rtcf import Component, ComponentSpec, JointLimits
from rtcf._core import _hotpath
from rtcf._core._clock import SimClock
from rtcf._core._runner import Runner
from rtcf._core._settings import RunnerSettings

SYSTEMS = {
    "plain": "(a) add_input, no check",
    "finite": "(b) command input, no limits (finite check)",
    "effort": "(c) effort limits, within",
    "position": "(d) position + max_velocity, within",
    "clamped": "(e) position + max_velocity, clamped every iteration",
}
PORTS = (1, 4)
JOINTS = (1, 7, 30)
FREQUENCY = 1000.0
# the limits of each system, and the value every joint is commanded
LIMITS: dict[str, tuple[str, JointLimits | None, float]] = {
    "finite": ("effort", None, 0.5),
    "effort": ("effort", JointLimits(max_effort=10.0), 0.5),
    "position": (
        "position",
        JointLimits(min_position=-1.0, max_position=1.0, max_velocity=2.0),
        0.5,
    ),
    "clamped": (
        "position",
        JointLimits(min_position=-1.0, max_position=1.0, max_velocity=2.0),
        2.0,
    ),
}


class Writer(Component):
    """Writes a fresh float64 array of ``~joints`` values to each of ``~ports`` outputs."""

    def configure(self) -> None:
        ports, joints = self.params.get("~ports"), self.params.get("~joints")
        self.outs = [self.add_output(f"cmd{i}", np.ndarray) for i in range(ports)]
        self.base = np.full(joints, float(self.params.get("~value")))

    def update(self) -> None:
        for out in self.outs:
            out.write(self.base.copy())


class Hardware(Component):
    """Reads each command port; ``~system`` says how they are declared."""

    def configure(self) -> None:
        ports, joints = self.params.get("~ports"), self.params.get("~joints")
        system = self.params.get("~system")
        names = [f"j{k}" for k in range(joints)]
        if system == "plain":
            self.ins = [self.add_input(f"cmd{i}", np.ndarray) for i in range(ports)]
        else:
            interface, limits, _ = LIMITS[system]
            self.ins = [
                self.add_command_input(
                    f"cmd{i}", interface, names, None if limits is None else [limits] * joints
                )
                for i in range(ports)
            ]

    def update(self) -> None:
        for port in self.ins:
            port.read()


def _runner(system: str, ports: int, joints: int) -> Runner:
    runner = Runner(
        RunnerSettings(frequency=FREQUENCY),
        clock=SimClock(),
        name=f"{system}-{ports}x{joints}",
        log_sink=lambda record: None,
    )
    value = LIMITS[system][2] if system in LIMITS else 0.5
    common = {"ports": ports, "joints": joints}
    runner.load(ComponentSpec("writer", Writer, params={**common, "value": value}))
    runner.load(ComponentSpec("hw", Hardware, params={**common, "system": system}))
    return runner


def _run(runner: Runner, n: int) -> float:
    """ns per iteration of one run of n iterations."""
    t0 = time.perf_counter_ns()
    runner.run(n)
    return (time.perf_counter_ns() - t0) / n


def _key(system: str, ports: int, joints: int) -> str:
    return f"{system}/{ports}/{joints}"


def measure(iterations: int, rounds: int) -> dict[str, Any]:
    """Per (system, ports, joints), the best ns per iteration of ``rounds`` runs, and
    what the guards of each counted (the clamped system must clamp, the others not)."""
    runners = {_key(s, p, j): _runner(s, p, j) for p in PORTS for j in JOINTS for s in SYSTEMS}
    load_before = [round(x, 2) for x in os.getloadavg()]
    t0 = time.monotonic()
    try:
        for runner in runners.values():
            _run(runner, 1000)  # warm
        best = dict.fromkeys(runners, float("inf"))
        for _ in range(rounds):
            for key, runner in runners.items():
                best[key] = min(best[key], _run(runner, iterations))
        clamped = {}
        for key, runner in runners.items():
            guards = runner._schedule.guards()
            clamped[key] = int(sum(int(g.clamped.sum()) + g.refused for g in guards))
    finally:
        for runner in runners.values():
            runner.shutdown()
    for key, n in clamped.items():  # the common path must stay common, the worst case clamp
        if (n > 0) != key.startswith("clamped/"):
            raise BenchmarkError(f"{key}: its guards clamped or refused {n} commands")
    return {
        "hot_path": _hotpath.describe(),
        "ns_per_iteration": best,
        "clamps_and_refusals": clamped,
        "seconds": round(time.monotonic() - t0, 1),
        "load_avg_before": load_before,
        "load_avg_after": [round(x, 2) for x in os.getloadavg()],
    }


def fit(ns: dict[str, float]) -> dict[str, dict[str, float]]:
    """Per guarded system, its difference to ``plain`` fitted (least squares over the
    port and joint counts) as ports * (per_port + per_joint * joints), in ns."""
    out = {}
    for system in list(SYSTEMS)[1:]:
        rows, diffs = [], []
        for p in PORTS:
            for j in JOINTS:
                rows.append([p, p * j])
                diffs.append(ns[_key(system, p, j)] - ns[_key("plain", p, j)])
        (per_port, per_joint), *_ = np.linalg.lstsq(
            np.array(rows, dtype=float), np.array(diffs), rcond=None
        )
        out[system] = {"per_port": float(per_port), "per_joint": float(per_joint)}
    return out


def tables(compiled: dict[str, Any], pure: dict[str, Any]) -> tuple[str, str]:
    """The table of every run (ns per iteration, the difference to plain, per port) and
    the table of the fitted costs per port and per joint."""
    c, p = compiled["ns_per_iteration"], pure["ns_per_iteration"]
    rows = []
    for ports in PORTS:
        for joints in JOINTS:
            for system, label in SYSTEMS.items():
                row = [label, str(ports), str(joints)]
                for ns in (c, p):
                    here = ns[_key(system, ports, joints)]
                    if system == "plain":
                        row += [fmt(here, 0), "", ""]
                    else:
                        diff = here - ns[_key("plain", ports, joints)]
                        row += [fmt(here, 0), f"{diff:+.0f}", f"{diff / ports:+.0f}"]
                rows.append(row)
    full = table(
        [
            "system",
            "ports",
            "joints",
            "compiled ns/it",
            "Δ to (a)",
            "Δ per port",
            "pure ns/it",
            "Δ to (a)",
            "Δ per port",
        ],
        rows,
    )
    fc, fp = compiled["fit"], pure["fit"]
    fitted = table(
        [
            "system",
            "compiled: per port",
            "per joint of a port",
            "pure: per port",
            "per joint of a port",
        ],
        [
            [
                SYSTEMS[s],
                fmt(fc[s]["per_port"], 0),
                fmt(fc[s]["per_joint"], 1),
                fmt(fp[s]["per_port"], 0),
                fmt(fp[s]["per_joint"], 1),
            ]
            for s in fc
        ],
    )
    return full, fitted


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--iterations",
        type=int,
        default=None,
        help="iterations per run (default 20000; 2000 with --quick)",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=None,
        help="runs per system, the best kept (default 5; 2 with --quick)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run of a few seconds: prints and writes "
        "results/command_limits-quick.json only",
    )
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    iterations = args.iterations or (2000 if args.quick else 20_000)
    rounds = args.rounds or (2 if args.quick else 5)
    if args.child:
        print(json.dumps(measure(iterations, rounds)))
        return 0
    machine = machine_info()
    t0 = time.monotonic()
    compiled = measure(iterations, rounds)
    env = dict(os.environ, RTCF_PURE_PYTHON="1")
    child = subprocess.run(
        [sys.executable, __file__, "--child", f"--iterations={iterations}", f"--rounds={rounds}"],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    pure = json.loads(child.stdout.splitlines()[-1])
    for result in (compiled, pure):
        result["fit"] = fit(result["ns_per_iteration"])
    full, fitted = tables(compiled, pure)
    intro = (
        f"ns per iteration of a writer and a hardware component on the simulated clock "
        f"({FREQUENCY:g} Hz, no sleep), best of {rounds} x {iterations} iterations in "
        f"alternating rounds; Δ: the difference to (a) at the same port and joint counts "
        f"(`benchmarks/command_limits.py`). Compiled: {compiled['hot_path']}; pure: "
        f"{pure['hot_path']}. Load average before and after: compiled "
        f"{compiled['load_avg_before']} → {compiled['load_avg_after']}, pure "
        f"{pure['load_avg_before']} → {pure['load_avg_after']}."
    )
    fit_intro = (
        "The difference to (a) fitted (least squares over the six port and joint "
        "counts) as ports * (per port + per joint * joints), ns:"
    )
    print(intro)
    print(full)
    print(fit_intro)
    print(fitted)
    print(f"total {time.monotonic() - t0:.0f} s")
    timestamp = now_iso()
    write_results(
        "command_limits",
        {
            "machine": machine,
            "timestamp": timestamp,
            "iterations": iterations,
            "rounds": rounds,
            "frequency": FREQUENCY,
            "ports": list(PORTS),
            "joints": list(JOINTS),
            "systems": SYSTEMS,
            "compiled": compiled,
            "pure": pure,
        },
        args.quick,
    )
    if not args.quick:
        publish_section("command_limits", [intro, full, fit_intro, fitted], machine, timestamp)
    return 0


if __name__ == "__main__":
    main_guard(main)
