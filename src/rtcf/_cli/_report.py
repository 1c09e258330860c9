"""What a run prints and writes: the order, the timing summary, timing.json."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path
from typing import Any

from .._core._histogram import LogHistogram
from .._core._runner import RunResult
from .._core._settings import RunnerSettings
from .._runtime._kernel_facts import kernel_preemption

_COLUMNS = ("min", "p50", "p99", "p999", "max")


def format_summary(result: RunResult, settings: RunnerSettings, wall_s: float) -> str:
    """A few lines that say what ran and how its timing looked."""
    t = result.timing
    clock = "simulated clock" if result.simulated else "system clock"
    lines = [
        f"ran {result.iterations} iterations at {settings.frequency:g} Hz on the {clock} "
        f"in {wall_s:.3f} s of wall time; overruns: {t.overruns}; "
        f"log records dropped: {result.log_records_dropped}"
    ]
    if result.simulated:
        rate = result.iterations / wall_s if wall_s > 0 else float("inf")
        lines.append(
            f"  simulated time: {result.iterations / settings.frequency:.3f} s "
            f"({rate:,.0f} iterations per second of wall time); timing is not measured"
        )
        return "\n".join(lines)
    if not t.calc_us:
        return "\n".join(lines)
    labels = ("min", "p50", "p99", "p99.9", "max")
    lines.append("  {:<28}".format("timing [µs]") + "".join(f"{c:>10}" for c in labels))

    def row(label: str, stats: dict[str, float]) -> str:
        return f"  {label:<28}" + "".join(f"{stats.get(c, float('nan')):>10.1f}" for c in _COLUMNS)

    lanes = len(result.lanes) > 1  # then the loop as a whole here, each lane below
    lines.append(row("wake-up jitter", t.jitter_us))
    lines.append(row("calculation (iteration)", t.calc_us))
    for name, stats in t.components_us.items() if not lanes else ():
        lines.append(row(f"  {name}", stats))
    # several rates: per phase of the hyperperiod; beyond a few, the most expensive
    phases = sorted(t.phases_us.items(), key=lambda kv: -kv[1].get("max", 0.0))
    shown = phases if len(phases) <= 8 else phases[:4]
    for phase, stats in sorted(shown):
        lines.append(row(f"calculation (phase {phase})", stats))
    if len(shown) < len(phases):
        lines.append(
            f"  (the {len(shown)} phases with the highest maximum of {len(phases)}; "
            "every phase is in timing.json)"
        )
    note = t.coverage_note()
    if note:
        lines.append(f"  ({note})")
    for name, lane in result.lanes.items():
        timing = lane.get("timing")
        if timing is None or not timing.calc_us:
            continue
        lines.append(
            f"  lane {name} ({lane.get('placement', '')}): {timing.iterations} "
            f"{'releases' if lane.get('every', 1) > 1 else 'iterations'}, "
            f"{'LET overruns (windows not finished)' if lane.get('every', 1) > 1 else 'overruns'}"
            f": {timing.overruns}"
        )
        lines.append(row("  wake-up jitter", timing.jitter_us))
        lines.append(row("  calculation", timing.calc_us))
        for comp, stats in timing.components_us.items():
            lines.append(row(f"    {comp}", stats))
    return "\n".join(lines)


def timing_document(result: RunResult, settings: RunnerSettings, wall_s: float) -> dict[str, Any]:
    """timing.json: what ran, what the worker applied, the quantiles and the histograms."""
    t = result.timing
    keep = ("min", "p50", "p90", "p99", "p999", "max", "mean")
    realtime = dict(result.realtime or {})
    realtime.setdefault("kernel_preemption", kernel_preemption())
    doc: dict[str, Any] = {
        "frequency_hz": settings.frequency,
        "iterations": result.iterations,
        "overruns": t.overruns,
        "duration_s": result.iterations / settings.frequency,
        "wall_time_s": wall_s,
        "simulated": result.simulated,
        "order": result.order,
        "realtime": realtime,
        "jitter_us": {k: t.jitter_us.get(k) for k in keep} if t.jitter_us else {},
        "calc_us": {k: t.calc_us.get(k) for k in keep} if t.calc_us else {},
        "components": {
            name: {"calc_us": {k: stats.get(k) for k in keep}}
            for name, stats in t.components_us.items()
        },
        # several rates: the iteration's calculation time per phase of the hyperperiod
        "phases": {
            str(phase): {"calc_us": {k: stats.get(k) for k in keep}}
            for phase, stats in t.phases_us.items()
        },
        "samples": t.samples,
        "timing_rows_dropped": t.iterations - t.samples if not result.simulated else 0,
        "log_records_dropped": result.log_records_dropped,
        "stopped_by": result.stopped_by,
        "faults": [f.to_dict() for f in result.faults],
        "safe_stops": [vars(o) for o in result.safe_stops],
        "machine": machine(),
    }
    if result.aggregate is not None and not result.simulated:
        doc["histograms_ns"] = result.aggregate.histograms()
    if result.inputs:  # mapped inputs: arrived, read, replaced by a newer one unread
        doc["inputs"] = result.inputs
    if result.deadlines:  # inputs with a deadline: how many times past it, how long in all
        doc["deadlines"] = result.deadlines
        doc["deadline_events"] = [e.to_dict() for e in result.deadline_events]
    if result.command_limits:  # hardware's command inputs: clamped per joint, refused
        doc["command_limits"] = result.command_limits
    if len(result.lanes) > 1:
        doc["lanes"] = {
            name: lane_document(lane, settings, keep) for name, lane in result.lanes.items()
        }
    return doc


def lane_document(
    lane: dict[str, Any], settings: RunnerSettings, keep: tuple[str, ...]
) -> dict[str, Any]:
    """One lane in timing.json: where it ran, its own timing, its handovers; a LET
    lane's margin to its deadline (its window less its calculation time)."""
    out: dict[str, Any] = {
        "every": lane.get("every", 1),
        "placement": lane.get("placement", "the runner's (main lane)"),
        "handovers": lane.get("handovers", {}),
        "releases_skipped": lane.get("missed", 0),
    }
    timing = lane.get("timing")
    if timing is not None:
        out.update(
            iterations=timing.iterations,
            overruns=timing.overruns,
            jitter_us={k: timing.jitter_us.get(k) for k in keep} if timing.jitter_us else {},
            calc_us={k: timing.calc_us.get(k) for k in keep} if timing.calc_us else {},
            components={
                name: {"calc_us": {k: stats.get(k) for k in keep}}
                for name, stats in timing.components_us.items()
            },
        )
        every = out["every"]
        if every > 1:  # a LET lane's windows it did not finish, counted per component
            out["let_overruns"] = {name: timing.overruns for name in timing.components_us
                                   if not name.startswith("@")}
        if every > 1 and timing.calc_us:
            window_us = every * 1e6 / settings.frequency
            out["let_window_us"] = window_us
            out["let_margin_us"] = {
                k: window_us - timing.calc_us[k] for k in ("p50", "p99", "max")
                if timing.calc_us.get(k) is not None
            }
    return out


def machine() -> dict[str, Any]:
    """Where the numbers were measured."""
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cores": os.cpu_count(),
        "cpu": model,
        "kernel": platform.release(),
        "kernel_version": platform.version(),
        "python": platform.python_version(),
        "load_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }


def can_plot() -> bool:
    """Whether matplotlib can be imported (timing.png needs it; timing.json does not)."""
    import importlib.util

    try:
        return importlib.util.find_spec("matplotlib") is not None
    except (ImportError, ValueError):
        return False


def write_report(
    directory: str | os.PathLike[str], result: RunResult, settings: RunnerSettings, wall_s: float
) -> list[Path]:
    """Write timing.json and, unless the clock was simulated, timing.png into ``directory``."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    doc = timing_document(result, settings, wall_s)
    path = out / "timing.json"
    path.write_text(json.dumps(doc, indent=2) + "\n")
    written = [path]
    if result.aggregate is not None and not result.simulated and can_plot():
        from ._plot import plot_timing  # matplotlib only when a plot is asked for

        m = doc["machine"]
        rt = doc["realtime"]
        sched = rt.get("scheduler", "?")
        if rt.get("priority"):
            sched += f" {rt['priority']}"
        written.append(
            plot_timing(
                out / "timing.png",
                result.aggregate.calc,
                result.aggregate.jitter,
                title=(
                    f"{len(result.order)} components at {settings.frequency:g} Hz, "
                    f"{result.iterations} iterations "
                    f"({result.iterations / settings.frequency:.0f} s)"
                ),
                subtitle=(
                    f"{m['cores']} cores {m['cpu']}, Linux {m['kernel']} "
                    f"({rt.get('kernel_preemption')}), {sched}, "
                    f"mlockall {'on' if rt.get('mlockall') else 'off'}, "
                    f"load {m['load_1min']:.2f}"
                ),
                lanes=_lane_histograms(result),
            )
        )
    return written


def _lane_histograms(result: RunResult) -> list[tuple[str, LogHistogram, LogHistogram]]:
    """Each lane (with lanes): its label, calculation and jitter."""
    if len(result.lanes) < 2:
        return []
    out = []
    for name, lane in result.lanes.items():
        aggregate = lane.get("aggregate")
        if aggregate is None:
            continue
        every = lane.get("every", 1)
        kind = f"LET, every {every}" if every > 1 else "lock step"
        out.append((f"lane {name} ({kind})", aggregate.calc, aggregate.jitter))
    return out
