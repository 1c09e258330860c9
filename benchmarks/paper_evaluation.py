"""The paper's evaluation: Fig. 1 at 2 kHz, idle and under stress-ng, next to cyclictest.

In each condition rtcf runs first and cyclictest second, one after the other, both at
SCHED_FIFO 80 on the same CPU with the same 500 µs period. Sequential, not parallel:
two SCHED_FIFO threads of equal priority on one CPU delay each other, so running them
together would measure their interference; one after the other, each sees the same
load and has the CPU to itself. cyclictest's latency is what the kernel and machine
allow a C thread; rtcf's wake-up jitter over that ratio is the cost of Python and of
the framework on wake-up. Only ratios carry over to other machines.

    .venv/bin/python benchmarks/paper_evaluation.py [--duration S] [--quick]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as c

NAME = "paper_evaluation"
FREQUENCY = 2000.0
INTERVAL_US = 500
TARGET_RATIO = 1.25


def run_condition(
    label: str, launch: Path, duration: float, work: Path, wrapper: list[str], load: bool
) -> dict[str, Any]:
    """rtcf, then cyclictest, in one condition (stress-ng around both when ``load``)."""
    before = c.load_avg()
    result: dict[str, Any] = {"condition": label, "load_avg_before": before}
    print(f"[{label}] rtcf then cyclictest, {duration:g} s each ...", file=sys.stderr)

    def measure() -> None:
        run = c.run_rtcf(launch, duration, work / f"report-{label}", wrapper=wrapper)
        result["rtcf"] = {
            "timing": run.timing,
            "realtime": c.rt_conditions(run),
            "setup_s": run.setup_s,
            "command": " ".join(run.command),
        }
        result["cyclictest"] = c.run_cyclictest(duration, interval_us=INTERVAL_US)

    with c.cpu_dma_latency_zero() as held:
        result["cpu_dma_latency_zero"] = held
        if load:
            # both runs, the tool start-ups and a margin; stopped in the finally of stress()
            with c.stress(timeout_s=2 * duration + 60) as info:
                result["stress_ng"] = info
                result["load_avg_start"] = c.load_avg()
                measure()
        else:
            result["stress_ng"] = None
            measure()
    result["load_avg_after"] = c.load_avg()
    return result


def report(results: list[dict[str, Any]]) -> tuple[str, str]:
    """The jitter table and the calculation table (markdown)."""
    jitter_rows, calc_rows = [], []
    for r in results:
        rj = r["rtcf"]["timing"]["jitter_us"]
        cj = r["cyclictest"]["latency_us"]
        jitter_rows.append([r["condition"], "rtcf wake-up jitter", *c.stat_cells(rj), "", ""])
        jitter_rows.append([r["condition"], "cyclictest latency", *c.stat_cells(cj), "", ""])
        rows_ratio = [c.ratio(rj.get(k), cj.get(k)) for k in c.COLUMNS]
        jitter_rows.append(
            [
                r["condition"],
                "ratio rtcf / cyclictest",
                *(c.fmt_ratio(x) for x in rows_ratio),
                "yes" if rows_ratio[3] <= TARGET_RATIO else "no",
                "yes" if rows_ratio[4] <= TARGET_RATIO else "no",
            ]
        )
        t = r["rtcf"]["timing"]
        calc_rows.append(
            [
                r["condition"],
                *c.stat_cells(t["calc_us"]),
                str(t["iterations"]),
                str(t["overruns"]),
            ]
        )
    jitter_rows.append(
        ["paper (C++, Preempt-RT, 3 h, stress-ng)", "RTCF jitter", "", "", "", "1.8", "6.1", "", ""]
    )
    paper = "paper (C++, Preempt-RT, 3 h, stress-ng)"
    calc_rows.append([paper, "", "", "", "10.3", "18.8", "", ""])
    jitter = c.table(
        ["condition", "series [µs]", *c.LABELS, "p99.9 ≤ 1.25x", "max ≤ 1.25x"], jitter_rows
    )
    calc = c.table(["condition / calculation [µs]", *c.LABELS, "iterations", "overruns"], calc_rows)
    return jitter, calc


def main() -> int:
    args = c.parser(__doc__.splitlines()[0], 60).parse_args()
    duration = args.duration or (2.0 if args.quick else 60.0)
    c.require_tools("cyclictest", "stress-ng")
    machine = c.machine_info()
    started = time.perf_counter()
    with c.workdir() as work:
        launch = work / "fig1.launch"
        launch.write_text(c.launch_xml(c.fig1_nodes(), frequency=FREQUENCY))
        wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
        results = [
            run_condition("idle", launch, duration, work, wrapper, load=False),
            run_condition("stress-ng", launch, duration, work, wrapper, load=True),
        ]
    elapsed = time.perf_counter() - started
    jitter, calc = report(results)
    print(f"machine: {c.machine_line(machine)}")
    load = " ".join(c.stress_args())
    print(f"Fig. 1 at {FREQUENCY:g} Hz, {duration:g} s per run; stress-ng {load}")
    print(jitter)
    print()
    print(calc)
    print(f"total {elapsed:.0f} s")
    data = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_run": duration,
        "frequency_hz": FREQUENCY,
        "interval_us": INTERVAL_US,
        "priority": c.PRIORITY,
        "cpu": c.RT_CPU,
        "stress_ng_args": c.stress_args(),
        "machine": machine,
        "paper": c.PAPER,
        "conditions": results,
        "elapsed_s": elapsed,
    }
    path = c.write_results(NAME, data, args.quick)
    print(f"wrote {path.relative_to(c.REPO)}")
    if not args.quick:
        rt = results[0]["rtcf"]["realtime"]
        how = (
            f"rtcf reported scheduler {rt.get('scheduler')}, priority {rt.get('priority')}, "
            f"mlockall {rt.get('mlockall')}, CPUs {rt.get('cpu_affinity')}"
        )
        if rt.get("wrapper"):
            how += f"; the benchmark ran it under `{rt['wrapper']}`"
        body = "\n".join(
            [
                f"Fig. 1 (H1 → F1 → R1, R2, R3) at {FREQUENCY:g} Hz; **{duration:g} s per run**, "
                f"rtcf then cyclictest in each condition (`cyclictest -m -p{c.PRIORITY} "
                f"-i{INTERVAL_US} -a {c.RT_CPU} -h 10000`, same priority and CPU); load: "
                f"`stress-ng {' '.join(c.stress_args())}` (the paper's 8 cpu + 8 io workers "
                f"per core). `/dev/cpu_dma_latency` held at 0 during every run (cyclictest "
                f"does that by itself; this gives rtcf the same machine). {how}.",
                "",
                "Wake-up jitter (rtcf: actual start minus scheduled start of an iteration; "
                "cyclictest: the same for its C thread, 1 µs buckets):",
                "",
                jitter,
                "",
                "Calculation time of a whole iteration (all five components):",
                "",
                calc,
                "",
                f"Machine: {c.machine_line(machine)}. Measured {data['timestamp']} "
                f"(`benchmarks/results/{NAME}.json`).",
            ]
        )
        c.update_doc_section(NAME, body)
        print(f"updated {c.DOC.relative_to(c.REPO)} (section {NAME})")
    return 0


if __name__ == "__main__":
    c.main_guard(main)
