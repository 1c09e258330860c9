"""How the loop's cost grows with the number of components: 10, 100 and 1000 in a chain.

The chain is one ``rtcf_examples Sine`` (a source that writes every iteration) feeding
N-1 ``rtcf_examples Identity`` components (in_port -> out_port, copied when new), so
every component reads and writes a port in every iteration. Each size runs at a rate
it can sustain, at SCHED_FIFO 80 on the loop's CPU, on rtcf's compiled hot path and on
its pure Python one (``RTCF_PURE_PYTHON=1``), one after the other. Per-component cost is the
iteration's p50 divided by N; launch time is the wall time from spawning ``rtcf`` until
the loop starts (an upper bound: the earlier of the CLI printing its ``real-time:``
line and printing ``ran N iterations`` minus the loop's duration).

    .venv/bin/python benchmarks/scaling.py [--duration S] [--quick]
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from typing import Any

import _common as c

NAME = "scaling"
SIZES = ((10, 1000.0), (100, 1000.0), (1000, 200.0))


def chain(n: int) -> list[c.Node]:
    """Sine -> Identity -> ... -> Identity, n components, topics /t0 ... /t(n-1)."""
    nodes = [c.Node("c0000", "rtcf_examples", "Sine", remaps=[("out", "/t0")])]
    nodes.extend(
        c.Node(
            f"c{k:04d}",
            "rtcf_examples",
            "Identity",
            remaps=[("in_port", f"/t{k - 1}"), ("out_port", f"/t{k}")],
        )
        for k in range(1, n)
    )
    return nodes


def interpreter_start_s() -> float:
    """Wall time of ``python -m rtcf --version``: the part of launch time that is not rtcf's."""
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "rtcf", "--version"], check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> int:
    args = c.parser(__doc__.splitlines()[0], 10).parse_args()
    duration = args.duration or (1.0 if args.quick else 10.0)
    machine = c.machine_info()
    started = time.perf_counter()
    results: list[dict[str, Any]] = []
    with c.workdir() as work, c.cpu_dma_latency_zero() as held:
        wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
        baseline = interpreter_start_s()
        for (n, frequency), path in ((size, p) for size in SIZES for p in c.HOT_PATHS):
            launch = work / f"chain{n}.launch"
            launch.write_text(c.launch_xml(chain(n), frequency=frequency))
            print(f"{n} components at {frequency:g} Hz, {path} hot path, {duration:g} s ...",
                  file=sys.stderr)
            run = c.run_rtcf_on(path, launch, duration, work / f"report{n}-{path}",
                                wrapper=wrapper)
            t = run.timing
            comps = t.get("components", {})
            identity_p50 = [
                v["calc_us"]["p50"] for k, v in comps.items() if k != "/c0000" and v.get("calc_us")
            ]
            results.append(
                {
                    "components": n,
                    "frequency_hz": frequency,
                    "hot_path": path,
                    "iterations": t["iterations"],
                    "overruns": t["overruns"],
                    "calc_us": t["calc_us"],
                    "jitter_us": t["jitter_us"],
                    "per_component_us": t["calc_us"]["p50"] / n,
                    "identity_component_p50_us_median": (
                        statistics.median(identity_p50) if identity_p50 else None
                    ),
                    "setup_s": run.setup_s,
                    "setup_source": run.setup_source,
                    "total_wall_s": run.total_wall_s,
                    "loop_wall_s": t.get("wall_time_s"),
                    "realtime": c.rt_conditions(run),
                }
            )
    elapsed = time.perf_counter() - started

    compiled_p50 = {r["components"]: r["calc_us"]["p50"] for r in results
                    if r["hot_path"] == "compiled"}
    rows = []
    for r in results:
        cu = r["calc_us"]
        rows.append(
            [
                str(r["components"]),
                f"{r['frequency_hz']:g}",
                r["hot_path"],
                c.fmt(cu["p50"]),
                c.fmt(cu["p999"]),
                c.fmt(cu["max"]),
                c.fmt(r["per_component_us"], 2),
                c.fmt_ratio(c.ratio(cu["p50"], compiled_p50[r["components"]])),
                c.fmt(r["identity_component_p50_us_median"], 2),
                str(r["overruns"]),
                c.fmt(r["jitter_us"]["p999"]),
                c.fmt(r["setup_s"], 2),
            ]
        )
    headers = [
        "components",
        "Hz",
        "hot path",
        "calc p50 [µs]",
        "calc p99.9",
        "calc max",
        "p50 / N [µs]",
        "p50 / compiled",
        "one Identity p50 [µs]",
        "overruns",
        "jitter p99.9 [µs]",
        "launch [s]",
    ]
    tab = c.table(headers, rows)
    compiled = [r for r in results if r["hot_path"] == "compiled"]
    first, last = compiled[0], compiled[-1]
    growth = (last["calc_us"]["p50"] / first["calc_us"]["p50"]) / (
        last["components"] / first["components"]
    )
    pure_ratio = ", ".join(
        f"{n}: {c.fmt_ratio(c.ratio(r['calc_us']['p50'], compiled_p50[n]))}"
        for r in results if r["hot_path"] == "pure" and (n := r["components"])
    )
    summary = (
        f"on the compiled hot path, calc p50 grows "
        f"{last['calc_us']['p50'] / first['calc_us']['p50']:.0f}x for "
        f"{last['components'] // first['components']}x the components "
        f"({growth:.2f} of linear); the pure Python hot path's calc p50 over the compiled "
        f"one's ({pure_ratio}); `python -m rtcf --version` alone takes {baseline:.2f} s"
    )
    c.print_report(machine, elapsed, tab, summary)
    data = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_run": duration,
        "machine": machine,
        "load_avg_after": c.load_avg(),
        "interpreter_start_s": baseline,
        "cpu_dma_latency_zero": held,
        "sizes": results,
        "elapsed_s": elapsed,
    }
    rt = compiled[0]["realtime"]
    how = f"rtcf reported scheduler {rt.get('scheduler')}" + (
        f", run under `{rt['wrapper']}`" if rt.get("wrapper") else ""
    )
    paragraphs = [
        f"A chain of one `Sine` and N-1 `Identity` components (every one reads and "
        f"writes a port each iteration), **{duration:g} s** per size and hot path "
        f"(compiled, and pure Python with `RTCF_PURE_PYTHON=1`), idle; {how}. "
        "Launch: wall time from spawning `rtcf launch` until the loop started "
        "(interpreter start, parsing, imports, loading, wiring, starting the worker, "
        "mlockall, pre-faulting), an upper bound: the earlier of the CLI printing its "
        "`real-time:` line and printing `ran N iterations` minus the loop's duration.",
        tab,
        summary + ".",
    ]
    c.write_results(NAME, data, args.quick, paragraphs)
    return 0


if __name__ == "__main__":
    c.main_guard(main)
