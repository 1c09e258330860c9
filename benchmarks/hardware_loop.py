"""What the hardware in the loop costs per iteration and per joint: mock_components/
GenericSystem read and written, a controller's states gathered and its command
scattered, in rtcf's loop against a plain Python loop doing the same numpy work.

In-process on the simulated clock (no sleep: the loop's own work only). Per number of
joints (1, 6, 24, 96; position command, position and velocity states), best of
``--rounds`` runs of ``--iterations`` iterations, ns per iteration:

* ``rtcf``: a Runner with the robot description: the read step, a controller whose
  ``update`` writes the positions it read (``add_state_interfaces`` /
  ``add_command_interfaces``, bound by key: gather, guard, scatter), the write step;
* ``plain``: a Python ``for`` loop: ``read_all``, ``np.take`` into a preallocated array,
  the same update's work, ``np.put``, ``write_all`` on the same resource manager.

A least-squares fit ``a + b * joints`` of each gives the cost per iteration and per
joint. Writes ``results/hardware_loop.json`` and its section of docs/performance.md.

    .venv/bin/python benchmarks/hardware_loop.py [--iterations N] [--rounds N] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import fmt, machine_info, main_guard, now_iso, table, write_results

from rtcf import Component, ComponentSpec
from rtcf._core import _hotpath
from rtcf._core._clock import SimClock
from rtcf._core._resource_manager import ResourceManager
from rtcf._core._runner import Runner
from rtcf._core._settings import RunnerSettings

JOINTS = (1, 6, 24, 96)


def urdf(n: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="continuous"><parent link="l{i}"/><child link="l{i + 1}"/>'
        "</joint>" for i in range(n))
    tags = "".join(
        f'<joint name="j{i}"><command_interface name="position"/>'
        '<state_interface name="position"/><state_interface name="velocity"/></joint>'
        for i in range(n))
    return (f'<robot name="r">{links}{joints}<ros2_control name="mock" type="system">'
            "<hardware><plugin>mock_components/GenericSystem</plugin></hardware>"
            f"{tags}</ros2_control></robot>")


class Follow(Component):
    """Commands the positions it reads (the controller's work: one write)."""

    def configure(self) -> None:
        n = int(self.params.get("~joints", 1))
        keys = [f"j{i}/position" for i in range(n)]
        self.position = self.add_state_interfaces("position", keys)
        self.command = self.add_command_interfaces("position_command", keys)

    def update(self) -> None:
        self.command.write(self.position.read())


def rtcf_ns(n: int, iterations: int) -> float:
    runner = Runner(RunnerSettings(frequency=1000.0, robot_description=urdf(n)),
                    clock=SimClock())
    runner.load(ComponentSpec("follow", cls=Follow, params={"joints": n}))
    runner.run(200)
    t0 = time.perf_counter_ns()
    runner.run(iterations)
    ns = (time.perf_counter_ns() - t0) / iterations
    runner.shutdown()
    return ns


def plain_ns(n: int, iterations: int) -> float:
    rm = ResourceManager.from_urdf(urdf(n), 1000)
    rm.set_initial_states()
    keys = [f"j{i}/position" for i in range(n)]
    sidx, cidx = rm.state_indices(keys), rm.command_indices(keys)
    bufs = (np.empty(n), np.empty(n))
    states, commands = rm.states, rm.commands
    read_all, write_all = rm.read_all, rm.write_all
    period = 0.001
    for k in range(200 + iterations):
        if k == 200:
            t0 = time.perf_counter_ns()
        t = k * period
        read_all(t, period)
        buf = bufs[k & 1]
        np.take(states, sidx, out=buf)
        value = buf  # the controller's work: the command is what it read
        np.put(commands, cidx, value)
        write_all(t, period)
    ns = (time.perf_counter_ns() - t0) / iterations
    rm.shutdown_components()
    return ns


def fit(xs: list[int], ys: list[float]) -> tuple[float, float]:
    b, a = np.polyfit(np.array(xs, dtype=float), np.array(ys), 1)
    return float(a), float(b)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=None,
                        help="iterations per run (default 20000; 1000 with --quick)")
    parser.add_argument("--rounds", type=int, default=None,
                        help="runs per system, the best kept (default 5; 1 with --quick)")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: prints and writes results/hardware_loop-quick.json")
    args = parser.parse_args()
    iterations = args.iterations or (1000 if args.quick else 20_000)
    rounds = args.rounds or (1 if args.quick else 5)
    machine = machine_info()
    timestamp = now_iso()
    best: dict[str, dict[int, float]] = {"rtcf": {}, "plain": {}}
    for _ in range(rounds):  # alternating: each round runs every system once
        for n in JOINTS:
            for name, measure in (("rtcf", rtcf_ns), ("plain", plain_ns)):
                ns = measure(n, iterations)
                best[name][n] = min(best[name].get(n, ns), ns)
    rows = [[str(n), fmt(best["rtcf"][n] / 1000, 2), fmt(best["plain"][n] / 1000, 2),
             fmt((best["rtcf"][n] - best["plain"][n]) / 1000, 2)] for n in JOINTS]
    full = table(["joints", "rtcf [µs/iteration]", "plain loop [µs]", "rtcf - plain [µs]"],
                 rows)
    fits = {name: fit(list(JOINTS), [best[name][n] for n in JOINTS]) for name in best}
    fitted = table(["loop", "per iteration [µs]", "per joint [ns]"], [
        [name, fmt(a / 1000, 2), fmt(b, 1)] for name, (a, b) in fits.items()])
    hot = "compiled" if _hotpath.HOT_PATH == "compiled" else "pure Python"
    intro = (f"Read, gather, scatter and write of one mock_components/GenericSystem with "
             f"a controller bound by key (rtcf's loop, {hot} hot path, simulated clock) "
             f"against a plain Python loop doing the same numpy work; best of {rounds} runs "
             f"of {iterations} iterations:")
    print(intro, full, fitted, sep="\n\n")
    data = {"machine": machine, "timestamp": timestamp, "iterations": iterations,
            "rounds": rounds, "hot_path": hot,
            "ns": {name: {str(n): v for n, v in d.items()} for name, d in best.items()},
            "fit": {name: {"per_iteration_ns": a, "per_joint_ns": b}
                    for name, (a, b) in fits.items()}}
    write_results("hardware_loop", data, args.quick, [intro, full, fitted])
    return 0


if __name__ == "__main__":
    main_guard(main)
