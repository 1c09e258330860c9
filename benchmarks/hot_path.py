"""What a trivial component costs: rtcf's hot path, compiled and in Python, against plain objects.

Issue 21's target: the framework's cost per trivial component within 1.5x of plain
Python objects. A chain of 200 components at 500 Hz, each reading one port, multiplying
once and writing one port (``rtcf_examples`` Ramp and 199 Gains), runs in rtcf with the
compiled hot path (``rtcf._core._compiled``) and with ``RTCF_PURE_PYTHON=1``; the same
chain as plain Python objects (``_plain_chain.py``: bound ``update`` methods called in
a for loop, no ports) is the reference, and the same with the clock read and stored
after every update (``--timed``) shows what per-component timing costs in plain Python.
All four run as their own process at SCHED_FIFO 80 on the same CPU, one after the other,
in alternating rounds; per component is the iteration's calculation p50 / 200 (the
median of the rounds' p50s).

    .venv/bin/python benchmarks/hot_path.py [--duration S] [--rounds N] [--quick]
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import _common as c

NAME = "hot_path"
FREQUENCY = 500.0
COMPONENTS = 200
TARGET_RATIO = 1.5
# system -> row label; rtcf's two paths and the two plain references
SYSTEMS = {
    "compiled": "rtcf, compiled hot path",
    c.CLOCK_GETTIME: "rtcf, compiled, components timed by clock_gettime (not the TSC)",
    "pure": "rtcf, pure Python hot path (RTCF_PURE_PYTHON=1)",
    "plain": "plain objects",
    "plain_timed": "plain objects, timed per component",
}


def chain() -> list[c.Node]:
    """Ramp -> Gain -> ... -> Gain, topics /t0 ... /t199."""
    nodes = [c.Node("c0000", "rtcf_examples", "Ramp", remaps=[("out", "/t0")])]
    nodes.extend(
        c.Node(
            f"c{k:04d}",
            "rtcf_examples",
            "Gain",
            remaps=[("in_port", f"/t{k - 1}"), ("out_port", f"/t{k}")],
        )
        for k in range(1, COMPONENTS)
    )
    return nodes


def run_rtcf(
    system: str, launch: Path, duration: float, report: Path, wrapper: list[str]
) -> dict[str, Any]:
    """One rtcf run on the hot path ``system`` names."""
    run = c.run_rtcf_on(system, launch, duration, report, wrapper=wrapper)
    t = run.timing
    gains = [v["calc_us"]["p50"] for k, v in t.get("components", {}).items() if k != "/c0000"]
    return {
        "iterations": t["iterations"],
        "overruns": t["overruns"],
        "calc_us": t["calc_us"],
        "jitter_us": t["jitter_us"],
        "gain_component_p50_us_median": statistics.median(gains) if gains else None,
        "steal_ms": run.steal_ms,
        "realtime": c.rt_conditions(run),
    }


def run_plain(timed: bool, duration: float) -> dict[str, Any]:
    """The plain chain in its own process, same priority and CPU as rtcf's loop."""
    return c.run_reference("_plain_chain.py", FREQUENCY, duration, "--components",
                           str(COMPONENTS), *(["--timed"] if timed else []))


def run_tight(pure: bool, clock_gettime: bool = False) -> dict[str, Any]:
    """The chain back to back in one process (``_tight_chain.py``): warm caches."""
    cmd = [sys.executable, str(Path(__file__).with_name("_tight_chain.py")),
           "--components", str(COMPONENTS), "--cpu", str(c.RT_CPU), "--priority",
           str(c.PRIORITY)]
    env = dict(os.environ)
    env.pop("RTCF_PURE_PYTHON", None)
    env.pop("RTCF_COMPONENT_CLOCK", None)
    if pure:
        env["RTCF_PURE_PYTHON"] = "1"
    if clock_gettime:
        env["RTCF_COMPONENT_CLOCK"] = "monotonic"
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if done.returncode != 0:
        raise c.BenchmarkError(f"tight loops failed (exit {done.returncode}): {done.stderr}")
    data: dict[str, Any] = json.loads(done.stdout)
    if data["hot_path"] != ("Python" if pure else "compiled"):
        raise c.BenchmarkError(f"tight loops ran the {data['hot_path']} hot path, not the asked")
    if clock_gettime and data["component_clock"] != "CLOCK_MONOTONIC":
        raise c.BenchmarkError("tight loops timed components by the TSC, not clock_gettime")
    return data


def breakdown(
    tight: dict[str, Any], per_ns: dict[str, float]
) -> tuple[dict[str, float], list[list[str]]]:
    """rtcf's cost per component, in parts: from plain objects in a Python loop (warm),
    what rtcf's loop adds around the same objects, what its ports add to the same bare
    loop, what the two add together beyond that, and what sleeping adds."""
    plain, rtcf = tight["plain"], tight["rtcf"]
    loop = tight["plain_in_rtcf_loop"] - plain
    ports = tight["rtcf_components_bare"] - plain
    parts = {
        "plain objects, called by a Python for loop (warm)": plain,
        "+ rtcf's loop around them: a call from C, the component clock, the timing row, "
        "the running word, the prefetch": loop,
        "+ rtcf's ports instead of attributes: two C method calls, a component's larger "
        "object": ports,
        "+ the two together, beyond their sum": rtcf - plain - loop - ports,
        "= rtcf, warm": rtcf,
        "+ the sleep between iterations: lines that come back from far caches": (
            per_ns["compiled"] - rtcf),
        "= rtcf in the 500 Hz loop": per_ns["compiled"],
        "(the plain objects in their 500 Hz loop, for reference; their sleep adds)": (
            per_ns["plain"] - plain),
    }
    return parts, [[k, f"{v:+.1f}" if k.startswith(("+", "(")) else f"{v:.1f}"]
                   for k, v in parts.items()]


def main() -> int:
    p = c.parser(__doc__.splitlines()[0], 10)
    p.add_argument("--rounds", type=int, default=None, metavar="N", help="3; 1 with --quick")
    args = p.parse_args()
    duration = args.duration or (1.0 if args.quick else 10.0)
    rounds = args.rounds or (1 if args.quick else 3)
    machine = c.machine_info()
    started = time.perf_counter()
    runs: dict[str, list[dict[str, Any]]] = {s: [] for s in SYSTEMS}
    with c.workdir() as work, c.cpu_dma_latency_zero() as held:
        wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
        launch = work / "chain.launch"
        launch.write_text(c.launch_xml(chain(), frequency=FREQUENCY))
        for r in range(rounds):
            # alternate the order: the host's noise drifts over minutes
            order = list(SYSTEMS) if r % 2 == 0 else list(reversed(SYSTEMS))
            for system in order:
                print(f"round {r + 1}/{rounds}: {system}, {duration:g} s ...", file=sys.stderr)
                if system in c.HOT_PATH_VARIANTS:
                    report = work / f"report-{system}-{r}"
                    runs[system].append(run_rtcf(system, launch, duration, report, wrapper))
                else:
                    runs[system].append(run_plain(system == "plain_timed", duration))
        print("tight loops (no sleep) ...", file=sys.stderr)
        tight = {"compiled": run_tight(False), "pure": run_tight(True),
                 c.CLOCK_GETTIME: run_tight(False, clock_gettime=True)}
    elapsed = time.perf_counter() - started

    def median(system: str, key: str) -> float:
        return statistics.median(x["calc_us"][key] for x in runs[system])

    per_ns = {s: median(s, "p50") * 1e3 / COMPONENTS for s in SYSTEMS}
    ratios = {s: c.ratio(per_ns[s], per_ns["plain"]) for s in SYSTEMS}
    rows = [
        [
            label,
            c.fmt(median(s, "p50")),
            c.fmt(median(s, "p99")),
            c.fmt(median(s, "p999")),
            c.fmt(max(x["calc_us"]["max"] for x in runs[s])),
            str(sum(x["overruns"] for x in runs[s])),
            c.fmt(per_ns[s]),
            c.fmt_ratio(ratios[s]),
        ]
        for s, label in SYSTEMS.items()
    ]
    headers = [
        f"{COMPONENTS} components at {FREQUENCY:g} Hz",
        "calc p50 [µs]",
        "p99",
        "p99.9",
        "max",
        "overruns",
        f"p50 / {COMPONENTS} [ns]",
        f"/ plain (target ≤ {TARGET_RATIO}x)",
    ]
    tab = c.table(headers, rows)
    steal = f"Steal time on CPU {c.RT_CPU} (/proc/stat) per run: " + "; ".join(
        f"{s} {', '.join(c.fmt(x['steal_ms'], 0) for x in runs[s])} ms" for s in SYSTEMS
    )
    met = not math.isnan(ratios["compiled"]) and ratios["compiled"] <= TARGET_RATIO
    verdict = (
        f"rtcf's compiled hot path costs {c.fmt_ratio(ratios['compiled'])} plain objects "
        f"per trivial component, target ≤ {TARGET_RATIO}x {'met' if met else 'NOT met'}; "
        f"pure Python {c.fmt_ratio(ratios['pure'])}; timing each component in plain Python "
        f"alone costs {c.fmt_ratio(ratios['plain_timed'])}"
    )
    plain_warm = min(t["plain"] for t in tight.values())
    plain_timed_warm = min(t["plain_timed"] for t in tight.values())
    warm = {
        "rtcf, compiled hot path": tight["compiled"]["rtcf"],
        "rtcf, compiled, components timed by clock_gettime": tight[c.CLOCK_GETTIME]["rtcf"],
        "rtcf, pure Python hot path": tight["pure"]["rtcf"],
        "plain objects": plain_warm,
        "plain objects, timed per component": plain_timed_warm,
    }
    tight_tab = c.table(
        ["in one process, no sleep (warm caches)", "ns per component", "/ plain"],
        [[k, c.fmt(v), c.fmt_ratio(c.ratio(v, plain_warm))] for k, v in warm.items()],
    )
    where, where_rows = breakdown(tight["compiled"], per_ns)
    where_tab = c.table(["where rtcf's nanoseconds per component go (compiled)", "ns"],
                        where_rows)
    c.print_report(
        machine,
        elapsed,
        f"median of {rounds} round(s) of {duration:g} s per system; "
        f"p99 and p99.9 medians, max over the rounds",
        tab,
        steal,
        tight_tab,
        where_tab,
        f"verdict: {verdict}",
    )
    data: dict[str, Any] = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_run": duration,
        "rounds": rounds,
        "frequency_hz": FREQUENCY,
        "components": COMPONENTS,
        "machine": machine,
        "load_avg_after": c.load_avg(),
        "cpu_dma_latency_zero": held,
        "per_component_ns": per_ns,
        "ratio_to_plain": ratios,
        "target_ratio": TARGET_RATIO,
        "target_met": met,
        "runs": runs,
        "tight_loops_ns_per_component": warm,
        "where_the_ns_go": where,
        "elapsed_s": elapsed,
    }
    rt = runs["compiled"][0]["realtime"]
    plain_rt = runs["plain"][0]["realtime"]
    how = c.against_plain(rt, plain_rt, "the plain chain")
    paragraphs = [
        f"A chain of one `Ramp` and {COMPONENTS - 1} `Gain` components (each reads a "
        f"port, multiplies once, writes a port) at {FREQUENCY:g} Hz, idle, "
        f"**{duration:g} s** per run in {rounds} alternating rounds, rtcf with each "
        "hot path and `benchmarks/_plain_chain.py` (the same chain as plain objects, "
        "bound `update` methods called in a for loop; timed: the clock read and "
        "stored after each update, as rtcf's loop does), `/dev/cpu_dma_latency` "
        f"held at 0. {how}. Per component: the median of the rounds' calculation "
        f"p50, divided by {COMPONENTS}. Target (issue 21): ≤ {TARGET_RATIO}x plain "
        "objects.",
        tab,
        steal + ".",
        "The same chain back to back in one process (`_tight_chain.py`, SCHED_FIFO, "
        "no sleep, so the caches stay warm; rtcf's figure is its recorded "
        "calculation p50 / 200):",
        tight_tab,
        "Where rtcf's nanoseconds per component go, from the same runs: the plain "
        "objects called by rtcf's own loop (its compiled `Calculation`), and rtcf's "
        "components (ports) called by a bare `for` loop, both warm; then what the "
        "sleep between iterations adds to each:",
        where_tab,
        verdict + ".",
    ]
    c.write_results(NAME, data, args.quick, paragraphs)
    return 0


if __name__ == "__main__":
    c.main_guard(main)
