"""The paper's evaluation: Fig. 1 at 2 kHz, idle and under stress-ng, next to cyclictest.

In each condition rtcf and cyclictest run one after the other, in alternating rounds
(rtcf first, then cyclictest first, ...), both at SCHED_FIFO 80 on the same CPU with
the same 500 µs period. Sequential, not parallel: two SCHED_FIFO threads of equal
priority on one CPU delay each other, so running them together would measure their
interference; one after the other, each has the CPU to itself under the same load, and
the rounds share out the host's noise, which drifts over minutes. cyclictest's latency
is what the kernel and machine allow a C thread; rtcf's wake-up jitter over it is the
cost of Python and of the framework on wake-up. Only ratios carry over to other machines.

    .venv/bin/python benchmarks/paper_evaluation.py [--duration S] [--rounds N] [--quick]
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import _common as c

NAME = "paper_evaluation"
FREQUENCY = 2000.0
INTERVAL_US = 500
TARGET_RATIO = 1.25


def run_condition(
    label: str,
    launch: Path,
    duration: float,
    rounds: int,
    work: Path,
    wrapper: list[str],
    load: bool,
) -> dict[str, Any]:
    """rtcf and cyclictest in alternating rounds in one condition (stress-ng around all).

    The host's noise drifts over minutes; alternating short rounds (rtcf first in even
    rounds, cyclictest first in odd ones) gives both tools the same share of it.
    """
    part = duration / rounds
    result: dict[str, Any] = {"condition": label, "load_avg_before": c.load_avg()}
    print(
        f"[{label}] rtcf and cyclictest, {rounds} alternating rounds of {part:g} s ...",
        file=sys.stderr,
    )
    runs: list[c.RtcfRun] = []
    cts: list[dict[str, Any]] = []

    def measure() -> None:
        for r in range(rounds):
            order = ("rtcf", "cyclictest") if r % 2 == 0 else ("cyclictest", "rtcf")
            for tool in order:
                if tool == "rtcf":
                    report = work / f"report-{label}-{r}"
                    runs.append(c.run_rtcf(launch, part, report, wrapper=wrapper))
                else:
                    cts.append(c.run_cyclictest(part, interval_us=INTERVAL_US))

    with c.cpu_dma_latency_zero() as held:
        result["cpu_dma_latency_zero"] = held
        if load:
            # all runs, the tool start-ups and a margin; stopped in the finally of stress()
            with c.stress(timeout_s=2 * duration + 20 * rounds + 60) as info:
                result["stress_ng"] = info
                result["load_avg_start"] = c.load_avg()
                measure()
        else:
            result["stress_ng"] = None
            measure()
    result["load_avg_after"] = c.load_avg()
    result["rtcf"] = merge_rtcf(runs)
    result["cyclictest"] = merge_cyclictest(cts)
    result["rounds"] = [
        {"rtcf_timing": slim(run.timing), "rtcf_setup_s": run.setup_s, "cyclictest": ct}
        for run, ct in zip(runs, cts, strict=True)
    ]
    return result


def slim(timing: dict[str, Any]) -> dict[str, Any]:
    """timing.json without the per-component histograms (most of its size; quantiles stay)."""
    out = dict(timing)
    hist = out.get("histograms_ns")
    if isinstance(hist, dict):
        out["histograms_ns"] = {k: v for k, v in hist.items() if k != "components"}
    return out


def merge_rtcf(runs: list[c.RtcfRun]) -> dict[str, Any]:
    """One rtcf series from its rounds (timing.json's own quantiles if there is one)."""
    timings = [run.timing for run in runs]
    if len(runs) == 1:
        jitter, calc = timings[0]["jitter_us"], timings[0]["calc_us"]
        quantiles_from = "timing.json quantiles"
    else:
        jitter = c.merge_ns_histograms([t["histograms_ns"]["jitter"] for t in timings])
        calc = c.merge_ns_histograms([t["histograms_ns"]["calc"] for t in timings])
        quantiles_from = "timing.json histograms_ns of all rounds, merged"
    late = sum(
        c.count_above(t["histograms_ns"]["jitter"], INTERVAL_US * 1000)
        for t in timings
        if "histograms_ns" in t
    )
    return {
        "jitter_us": jitter,
        "calc_us": calc,
        "quantiles_from": quantiles_from,
        "iterations": sum(t["iterations"] for t in timings),
        "overruns": sum(t["overruns"] for t in timings),
        "late_by_a_period": late,
        "steal_ms": sum(run.steal_ms for run in runs),
        "realtime": c.rt_conditions(runs[0]),
        "command": " ".join(runs[0].command),
    }


def merge_cyclictest(cts: list[dict[str, Any]]) -> dict[str, Any]:
    """One cyclictest series from its rounds: histograms summed, then nearest rank."""
    hist: dict[int, int] = {}
    for ct in cts:
        for k, v in ct["histogram"].items():
            hist[int(k)] = hist.get(int(k), 0) + v
    overflows = sum(ct["overflows"] for ct in cts)
    stats = c.histogram_quantiles(hist, overflows, max(ct["latency_us"]["max"] for ct in cts))
    stats["min"] = min(ct["latency_us"]["min"] for ct in cts)
    return {
        "latency_us": stats,
        "samples": sum(ct["samples"] for ct in cts),
        "overflows": overflows,
        "late_by_a_period": sum(v for k, v in hist.items() if k >= INTERVAL_US) + overflows,
        "steal_ms": sum(ct["steal_ms"] for ct in cts),
        "command": cts[0]["command"],
    }


def by_condition(
    results: list[dict[str, Any]],
    rtcf: Callable[[dict[str, Any]], str],
    cyclictest: Callable[[dict[str, Any]], str],
) -> str:
    """``condition: rtcf ..., cyclictest ...`` for each condition, ``; `` between them,
    each tool's part shown by its function of that tool's results."""
    return "; ".join(
        f"{r['condition']}: rtcf {rtcf(r['rtcf'])}, cyclictest {cyclictest(r['cyclictest'])}"
        for r in results
    )


def steal_line(results: list[dict[str, Any]]) -> str:
    """Hypervisor steal time on the loop's CPU: evidence for outliers that are not ours."""
    def ms(t: dict[str, Any]) -> str:
        return f"{c.fmt(t['steal_ms'], 0)} ms"

    return f"Steal time on CPU {c.RT_CPU} during the runs (/proc/stat): " + by_condition(
        results, ms, ms
    )


def late_line(results: list[dict[str, Any]]) -> str:
    """Wake-ups later than a whole period: rtcf counts every catch-up iteration of a stall."""
    return f"Later than one period ({INTERVAL_US} µs): " + by_condition(
        results,
        lambda t: f"{t['late_by_a_period']} iterations",
        lambda t: f"{t['late_by_a_period']} samples",
    )


def report(results: list[dict[str, Any]]) -> tuple[str, str]:
    """The jitter table and the calculation table (markdown)."""
    jitter_rows, calc_rows = [], []
    for r in results:
        rj = r["rtcf"]["jitter_us"]
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
        t = r["rtcf"]
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
    p = c.parser(__doc__.splitlines()[0], 60)
    p.add_argument(
        "--rounds",
        type=int,
        default=None,
        help="alternating rounds per condition that share the duration (default 4; 1 quick)",
    )
    p.add_argument(
        "--wait-policy",
        choices=["absolute", "relative"],
        default="absolute",
        help="rtcf's wait_policy (default absolute, as shipped; relative re-anchors the grid "
        "after an overrun, so a stall counts once, as in cyclictest); other than absolute, "
        "results go to results/paper_evaluation-<policy>.json and the docs are left alone",
    )
    args = p.parse_args()
    duration = args.duration or (2.0 if args.quick else 60.0)
    rounds = max(1, args.rounds or (1 if args.quick else 4))
    c.require_tools("cyclictest", "stress-ng")
    machine = c.machine_info()
    started = time.perf_counter()
    with c.workdir() as work:
        launch = work / "fig1.launch"
        launch.write_text(
            c.launch_xml(c.fig1_nodes(), frequency=FREQUENCY, wait_policy=args.wait_policy)
        )
        wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
        results = [
            run_condition("idle", launch, duration, rounds, work, wrapper, load=False),
            run_condition("stress-ng", launch, duration, rounds, work, wrapper, load=True),
        ]
    elapsed = time.perf_counter() - started
    jitter, calc = report(results)
    load = " ".join(c.stress_args())
    c.print_report(
        machine,
        elapsed,
        f"Fig. 1 at {FREQUENCY:g} Hz, {duration:g} s per tool and condition in {rounds} "
        f"rounds; rtcf wait_policy {args.wait_policy}; stress-ng {load}",
        jitter,
        late_line(results),
        steal_line(results),
        "",
        calc,
    )
    data = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_tool_and_condition": duration,
        "rounds": rounds,
        "wait_policy": args.wait_policy,
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
    shipped = args.wait_policy == "absolute"
    name = NAME if shipped else f"{NAME}-{args.wait_policy}"
    rt = results[0]["rtcf"]["realtime"]
    how = (
        f"rtcf reported scheduler {rt.get('scheduler')}, priority {rt.get('priority')}, "
        f"mlockall {rt.get('mlockall')}, CPUs {rt.get('cpu_affinity')}"
    )
    if rt.get("wrapper"):
        how += f"; the benchmark ran it under `{rt['wrapper']}`"
    paragraphs = [
        f"Fig. 1 (H1 → F1 → R1, R2, R3) at {FREQUENCY:g} Hz; **{duration:g} s per tool "
        f"and condition**, in {rounds} alternating rounds of rtcf and cyclictest "
        f"(`cyclictest -m -p{c.PRIORITY} -i{INTERVAL_US} -a {c.RT_CPU} -h 10000`, same "
        "priority and CPU; rtcf's quantiles from its merged histograms); load: "
        f"`stress-ng {' '.join(c.stress_args())}` (the paper's 8 cpu + 8 io workers "
        f"per core). `/dev/cpu_dma_latency` held at 0 during every run (cyclictest "
        f"does that by itself; this gives rtcf the same machine). {how}. rtcf's "
        "wait_policy is absolute, as shipped: after a stall the late iterations run "
        "back to back and each counts as late, while cyclictest skips the missed "
        "periods and counts a stall once (see the line under the table).",
        "Wake-up jitter (rtcf: actual start minus scheduled start of an iteration; "
        "cyclictest: the same for its C thread, 1 µs buckets):",
        jitter,
        late_line(results) + ". " + steal_line(results) + ".",
        "Calculation time of a whole iteration (all five components):",
        calc,
    ]
    c.write_results(name, data, args.quick, paragraphs if shipped else ())
    return 0


if __name__ == "__main__":
    c.main_guard(main)
