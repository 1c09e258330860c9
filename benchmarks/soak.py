"""Soak: Fig. 1 plus a component that logs and publishes every iteration, at 2 kHz for an hour.

The paper's Fig. 1 (H1, F1, R1-R3 from ``paper_evaluation.launch``, SCHED_FIFO 80 on
one CPU, memory locked, the heap and stack pre-faulted) runs with one more
component, ``_soak.SeqLogger``, which every iteration logs ``seq N`` and writes N on
an output mapped to the ROS 2 topic ``/soak/seq`` (std_msgs/Int64). The supervisor is
wired as ``rtcf launch --middleware ros2`` wires it (``_soak.py supervisor``), so
every record also goes to /rosout and every iteration to ``~/iteration_info``. Over
the run this checks, exactly:

* **memory**: VmRSS of the supervisor and of the worker, sampled every minute (every
  5 s with --quick), stays within ``--memory-limit-kb`` after the first minute;
* **logs**: every record written is either delivered (a line on the supervisor's
  stderr, where ``rtcf launch`` writes them; sequence numbers checked in order) or
  counted in the run's ``log records dropped``: delivered + dropped == written;
* **messages**: a separate rclpy process counts what arrives on the topic, with
  sequence gaps: received + what the bridge reported dropped (channel full,
  oversize) == written;
* **overruns**: the loop's overrun count equals the overrun rows the supervisor
  aggregated (and no timing row was dropped);
* **tail jitter over time**: p99, p99.9 and the exact maximum of the wake-up jitter
  per window (a minute; 5 s with --quick), from the timing rows the supervisor
  drains (every row of the run, not a sample).

The mapped topic uses a reliable, transient-local QoS with a history of 2 s of
messages (``ros_qos_depth`` 4000): the default (keep last 10, volatile) is
latest-value semantics, which loses messages by design before discovery and
whenever a subscriber falls 5 ms behind. The machine is not reserved: whatever
else runs on it is recorded (load average, other real-time processes) per sample.

    .venv-ros2/bin/python benchmarks/soak.py [--minutes M] [--quick]

Exit status 1 if a check fails (with --quick the memory check is reported but not
enforced: a minute cannot tell warm-up from drift), 2 without rclpy.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import json
import math
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import _common as c

NAME = "soak"
BENCH = Path(__file__).resolve().parent
SRC = c.REPO / "src"
FREQUENCY = 2000.0
MINUTES = 60.0
QUICK_MINUTES = 0.75
TOPIC = "/soak/seq"
LOGGER = "/logger"  # the SeqLogger's full name
QOS_DEPTH = 20000  # 10 s at 2 kHz
MEMORY_LIMIT_KB = 300
HEARTBEAT_TIMEOUT_S = 60.0  # the runner's default is 1 s; why not here: soak_launch
RT_SCAN_S = 5.0  # how often other real-time processes are looked for

_SEQ_LINE = re.compile(r"^\[INFO\] #(\d+) \[" + re.escape(LOGGER) + r"\]: seq (\d+)$")
_DROP_NOTE = re.compile(r"(\d+) messages on (\S+) were dropped")
_OVERSIZE_NOTE = re.compile(r"(\d+) messages on (\S+) were larger than a channel record")


# -- the launch file ------------------------------------------------------------------


def soak_launch(counts_file: Path, frequency: float) -> str:
    """Fig. 1 as the paper's launch file has it, plus the SeqLogger after R3."""
    logger = c.Node(
        LOGGER.strip("/"),
        "_soak",
        "SeqLogger",
        remaps=[("in", "/R3_out2"), ("seq", TOPIC)],
        params={"counts_file": f'"{counts_file}"'},
    )
    return c.launch_xml(
        [*c.fig1_nodes(), logger],
        frequency=frequency,
        runner_params={
            "safe_heap_size_kB": "4096",  # as paper_evaluation.launch
            "safe_stack_size_kB": "512",
            "ros_mapping_whitelist": f'"{TOPIC}"',
            "ros_qos_depth": str(QOS_DEPTH),
            "ros_qos_reliability": '"reliable"',
            "ros_qos_durability": '"transient_local"',
            # the watch counts iterations: after a stall, the late iterations run back to
            # back and 1 s of them (2000) can pass while the supervisor drains the burst
            # in one long pump, which reads as a dead supervisor (see docs/performance.md)
            "heartbeat_timeout": str(HEARTBEAT_TIMEOUT_S),
        },
    )


# -- processes ---------------------------------------------------------------------------


def child_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(SRC), str(BENCH), env.get("PYTHONPATH", "")) if p
    )
    env["PYTHONUNBUFFERED"] = "1"
    return env


class LogCounter:
    """Counts the SeqLogger's records among the supervisor's stderr lines, as they come.

    Constant memory however long the run: counters, the first gap runs, the first and
    last other lines.
    """

    def __init__(self, window: int) -> None:
        self.window = window
        self.delivered = 0
        self.last = 0  # highest sequence number seen
        self.missing = 0  # numbers skipped
        self.disorder = 0  # a number not above the last one
        self.iteration_mismatch = 0  # seq N not logged in iteration N-1
        self.gap_runs: list[list[int]] = []  # [first missing, how many], the first 100
        self.per_window: collections.Counter[int] = collections.Counter()
        self.bridge_dropped: dict[str, int] = {}
        self.oversize: dict[str, int] = {}
        self.first_other: list[str] = []
        self.last_other: collections.deque[str] = collections.deque(maxlen=20)
        self.other = 0

    def line(self, text: str) -> None:
        m = _SEQ_LINE.match(text)
        if m is None:
            self._other(text)
            return
        iteration, seq = int(m.group(1)), int(m.group(2))
        self.delivered += 1
        self.per_window[(seq - 1) // self.window] += 1
        if iteration != seq - 1:
            self.iteration_mismatch += 1
        if seq <= self.last:
            self.disorder += 1
            return
        if seq > self.last + 1:
            self.missing += seq - self.last - 1
            if len(self.gap_runs) < 100:
                self.gap_runs.append([self.last + 1, seq - self.last - 1])
        self.last = seq

    def _other(self, text: str) -> None:
        self.other += 1
        if len(self.first_other) < 100:
            self.first_other.append(text)
        else:
            self.last_other.append(text)
        m = _DROP_NOTE.search(text)
        if m:
            self.bridge_dropped[m.group(2)] = self.bridge_dropped.get(m.group(2), 0) + int(
                m.group(1)
            )
        m = _OVERSIZE_NOTE.search(text)
        if m:
            self.oversize[m.group(2)] = self.oversize.get(m.group(2), 0) + int(m.group(1))


class Proc(c.ChildProcess):
    """A child whose stdout JSON events and stderr lines are handled as they come."""

    def __init__(self, label: str, cmd: Sequence[str], on_err: Any = None) -> None:
        self.events: list[dict[str, Any]] = []
        self.other_stdout: collections.deque[str] = collections.deque(maxlen=20)
        self.stderr_tail: collections.deque[str] = collections.deque(maxlen=20)
        self._on_err = on_err
        super().__init__(label, cmd, child_env())

    def _read_out(self) -> None:
        assert self.proc.stdout is not None
        for line in iter(self.proc.stdout.readline, ""):
            try:
                event = json.loads(line)
            except ValueError:
                event = None
            with self._cond:
                if isinstance(event, dict) and "event" in event:
                    event["_at"] = time.monotonic()
                    if event["event"] == "progress" and self.events:
                        if self.events[-1]["event"] == "progress":
                            self.events[-1] = event  # keep only the newest
                            self._cond.notify_all()
                            continue
                    self.events.append(event)
                else:
                    self.other_stdout.append(line.rstrip())
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def _read_err(self) -> None:
        assert self.proc.stderr is not None
        for line in iter(self.proc.stderr.readline, ""):
            text = line.rstrip("\n")
            if self._on_err is not None:
                self._on_err(text)
            else:
                self.stderr_tail.append(text)
        with self._cond:
            self._cond.notify_all()

    def event(self, name: str) -> dict[str, Any] | None:
        with self._cond:
            return next((e for e in reversed(self.events) if e["event"] == name), None)

    def wait_event(self, name: str, timeout: float) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                found = next((e for e in self.events if e["event"] == name), None)
                if found is not None:
                    return found
                if self.proc.poll() is not None and not self._threads[0].is_alive():
                    raise c.BenchmarkError(
                        f"{self.label} ended (exit {self.proc.returncode}) before {name!r}: "
                        f"{self.tail()}"
                    )
                left = deadline - time.monotonic()
                if left <= 0:
                    raise c.BenchmarkError(f"{self.label}: no {name!r} in {timeout:g} s")
                self._cond.wait(min(left, 0.5))

    def tail(self) -> str:
        return " | ".join(list(self.stderr_tail)[-3:]) or "no output"

    def finish(self, timeout: float, join_s: float = 10.0) -> int:
        return super().finish(timeout, join_s)

    def stop(self, grace_s: float = 15.0) -> int | None:
        return super().stop(grace_s)


# -- what /proc says --------------------------------------------------------------------

_STATUS_KEYS = ("VmRSS", "RssAnon", "RssFile", "RssShmem", "VmHWM", "VmLck", "Threads")


def proc_status(pid: int | None) -> dict[str, int]:
    """Memory (kB) and threads of a process from /proc/PID/status; {} once it is gone."""
    out: dict[str, int] = {}
    if pid is None:
        return out
    with contextlib.suppress(OSError):
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in _STATUS_KEYS:
                out[key] = int(value.split()[0])
    return out


def cpu_seconds(pid: int | None) -> float:
    """User plus system time of a process (all its threads) so far."""
    with contextlib.suppress(OSError, IndexError, ValueError, TypeError):
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return math.nan


def _describe(pid: str) -> str:
    """What a process runs: a Python script or module, or its command name."""
    with contextlib.suppress(OSError):
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace").split("\0")
        argv = [a for a in argv if a]
        if argv and "python" in Path(argv[0]).name and len(argv) > 1:
            if argv[1] == "-m" and len(argv) > 2:
                return f"python -m {argv[2]}"
            return f"python {Path(argv[1]).name}"
        if argv:
            return Path(argv[0]).name
    return "?"


def other_rt_processes(exclude: set[int]) -> list[dict[str, Any]]:
    """User processes at SCHED_FIFO or SCHED_RR other than ours, and where they may run."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) in exclude:
            continue
        with contextlib.suppress(OSError, IndexError, ValueError):
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            ppid, prio, policy = int(fields[1]), int(fields[37]), int(fields[38])
            if policy not in (1, 2) or ppid == 2 or entry.name == "2":  # no kernel threads
                continue
            cpus = next(
                line.split(":", 1)[1].strip()
                for line in (entry / "status").read_text().splitlines()
                if line.startswith("Cpus_allowed_list")
            )
            found.append(
                {
                    "pid": int(entry.name),
                    "what": _describe(entry.name),
                    "priority": prio,
                    "cpus": cpus,
                }
            )
    return found


def sample(
    t_s: float, pids: dict[str, int | None], phase: str, seen: dict[int, dict[str, Any]]
) -> dict[str, Any]:
    """One memory sample, with the other real-time processes seen since the last one."""
    ours = {p for p in pids.values() if p}
    for p in other_rt_processes(ours | {os.getpid()}):
        seen.setdefault(p["pid"], p)
    others = sorted(seen.values(), key=lambda p: p["pid"])
    seen.clear()
    return {
        "t_s": round(t_s, 2),
        "phase": phase,
        "load_avg": c.load_avg(),
        "steal_ms_rt_cpu": c.steal_ms(),
        "memory_kb": {k: proc_status(p) for k, p in pids.items()},
        "cpu_s": {k: cpu_seconds(p) for k, p in pids.items()},
        "other_rt_processes": others,
    }


# -- the checks ---------------------------------------------------------------------------


def memory_check(
    samples: list[dict[str, Any]], warmup_s: float, limit_kb: int
) -> dict[str, dict[str, Any]]:
    """Per process: VmRSS at the end of the warm-up, at the end, drift, range after."""
    out: dict[str, dict[str, Any]] = {}
    for proc in ("supervisor", "worker"):
        series = [
            (s["t_s"], s["memory_kb"][proc]["VmRSS"])
            for s in samples
            if s["phase"] == "loop" and "VmRSS" in s["memory_kb"].get(proc, {})
        ]
        after = [v for t, v in series if t >= warmup_s - 0.5]
        if len(after) < 2:
            out[proc] = {"ok": False, "why": f"fewer than 2 samples after {warmup_s:g} s"}
            continue
        first = series[0][1]
        out[proc] = {
            "at_start_kb": first,
            "after_warmup_kb": after[0],
            "end_kb": after[-1],
            "max_kb": max(after),
            "min_kb": min(after),
            "drift_kb": after[-1] - after[0],
            "range_kb": max(after) - min(after),
            "warmup_growth_kb": after[0] - first,
            "samples_after_warmup": len(after),
            "limit_kb": limit_kb,
            "ok": max(after) - min(after) <= limit_kb,
        }
    return out


def heap_line(windows: list[dict[str, Any]], warmup_s: float) -> str:
    """The supervisor's glibc heap (mallinfo2) from the first window after the warm-up
    to the last: memory in use against free memory kept inside the heap, which tells
    a leak (in use grows) from fragmentation (free grows, in use does not)."""
    heap = [w["malloc_kb"] for w in windows if w.get("malloc_kb") and w["t_s"] >= warmup_s]
    if len(heap) < 2:
        return "supervisor heap (glibc mallinfo2): fewer than 2 windows after the warm-up"
    a, b = heap[0], heap[-1]
    return (
        f"supervisor heap (glibc mallinfo2), first window after the warm-up → last: "
        f"in use {kb(a['in_use'])} → {kb(b['in_use'])} kB ({b['in_use'] - a['in_use']:+,d}), "
        f"free inside the heap {kb(a['free'])} → {kb(b['free'])} kB "
        f"({b['free'] - a['free']:+,d})"
        + (
            f"; CPython's blocks {kb(a['py_blocks'])} → {kb(b['py_blocks'])} "
            f"({b['py_blocks'] - a['py_blocks']:+,d})"
            if "py_blocks" in a and "py_blocks" in b
            else ""
        )
    )


def log_check(written: int, dropped: int, logs: LogCounter) -> dict[str, Any]:
    # records the supervisor never delivered: skipped numbers, and any after the last
    unseen = logs.missing + written - logs.last
    ok = (
        logs.delivered + dropped == written
        and unseen == dropped
        and logs.disorder == 0
        and logs.last <= written
        and logs.iteration_mismatch == 0
    )
    return {
        "written": written,
        "delivered": logs.delivered,
        "dropped_reported": dropped,
        "unseen_sequence_numbers": unseen,
        "out_of_order_or_repeated": logs.disorder,
        "iteration_mismatch": logs.iteration_mismatch,
        "highest_delivered": logs.last,
        "gap_runs": logs.gap_runs,
        "ok": ok,
    }


def message_check(written: int, logs: LogCounter, sub: dict[str, Any]) -> dict[str, Any]:
    dropped = logs.bridge_dropped.get(TOPIC, 0)
    oversize = logs.oversize.get(TOPIC, 0)
    received = int(sub.get("received", 0))
    last, first = int(sub.get("last", 0)), int(sub.get("first", 0))
    # numbers that never arrived: before the first, skipped, after the last
    unseen = max(first - 1, 0) + int(sub.get("missing", 0)) + written - last
    repeated = int(sub.get("duplicates_or_reordered", 0))
    ok = (
        received + dropped + oversize == written
        and unseen == dropped + oversize
        and repeated == 0
        and last <= written
    )
    return {
        "written": written,
        "bridge_dropped_reported": dropped,
        "oversize_reported": oversize,
        "published": written - dropped - oversize,
        "received": received,
        "unseen_sequence_numbers": unseen,
        "first_received": first,
        "last_received": last,
        "duplicates_or_reordered": repeated,
        "gap_runs": sub.get("gap_runs", []),
        "ok": ok,
    }


def overrun_check(result: dict[str, Any], windows: list[dict[str, Any]]) -> dict[str, Any]:
    window_rows = sum(w["rows"] for w in windows)
    window_overruns = sum(w["overrun_rows"] for w in windows)
    ok = (
        result["overruns_loop"] == result["overrun_rows"] == window_overruns
        and result["timing_rows_dropped"] == 0
        and result["timing_rows"] == window_rows == result["iterations"]
    )
    return {
        "overruns_counted_by_loop": result["overruns_loop"],
        "overrun_rows_aggregated": result["overrun_rows"],
        "overrun_rows_in_windows": window_overruns,
        "timing_rows": result["timing_rows"],
        "timing_rows_in_windows": window_rows,
        "timing_rows_dropped": result["timing_rows_dropped"],
        "iterations": result["iterations"],
        "ok": ok,
    }


# -- report -------------------------------------------------------------------------------


def kb(x: float | None) -> str:
    return "-" if x is None else f"{x:,.0f}"


def memory_table(check: dict[str, dict[str, Any]], warmup_s: float) -> str:
    rows = []
    for proc, m in check.items():
        if "end_kb" not in m:
            rows.append([proc, "-", "-", "-", "-", "-", m.get("why", "")])
            continue
        rows.append(
            [
                proc,
                kb(m["at_start_kb"]),
                kb(m["after_warmup_kb"]),
                kb(m["end_kb"]),
                f"{m['drift_kb']:+,d}",
                kb(m["range_kb"]),
                "yes" if m["ok"] else "NO",
            ]
        )
    after = f"{warmup_s / 60:g} min" if warmup_s >= 60 else f"{warmup_s:g} s"
    return c.table(
        [
            "VmRSS [kB]",
            "loop start",
            f"at {after}",
            "end",
            "drift",
            f"range after {after}",
            f"range ≤ {next(iter(check.values())).get('limit_kb', MEMORY_LIMIT_KB)} kB",
        ],
        rows,
    )


def accounting_table(logs: dict[str, Any], msgs: dict[str, Any], ovr: dict[str, Any]) -> str:
    rows = [
        [
            "log records (stderr lines)",
            str(logs["written"]),
            str(logs["delivered"]),
            f"{logs['dropped_reported']} (log ring full)",
            f"{logs['delivered']} + {logs['dropped_reported']} == {logs['written']}",
            "yes" if logs["ok"] else "NO",
        ],
        [
            f"messages on {TOPIC}",
            str(msgs["written"]),
            str(msgs["received"]),
            f"{msgs['bridge_dropped_reported']} (channel full) + {msgs['oversize_reported']} "
            "(oversize)",
            f"{msgs['received']} + {msgs['bridge_dropped_reported'] + msgs['oversize_reported']}"
            f" == {msgs['written']}",
            "yes" if msgs["ok"] else "NO",
        ],
        [
            "overruns",
            str(ovr["overruns_counted_by_loop"]),
            str(ovr["overrun_rows_aggregated"]),
            f"{ovr['timing_rows_dropped']} timing rows dropped",
            f"{ovr['overrun_rows_aggregated']} rows == {ovr['overruns_counted_by_loop']} counted",
            "yes" if ovr["ok"] else "NO",
        ],
    ]
    return c.table(
        [
            "accounting",
            "written / counted",
            "delivered / recorded",
            "reported dropped",
            "check",
            "exact",
        ],
        rows,
    )


def jitter_table(run: dict[str, Any], windows: list[dict[str, Any]], window_s: float) -> str:
    """Whole-run quantiles, and the lowest, median and highest per-window p99 and max."""
    label = f"{window_s / 60:g} min" if window_s >= 60 else f"{window_s:g} s"
    rows = []
    for series, name in (("jitter_us", "wake-up jitter"), ("calc_us", "calculation")):
        whole = run[series]
        cells = [name, *(c.fmt(whole.get(k)) for k in ("p50", "p99", "p999", "max"))]
        for key in ("p99", "max"):
            vals = sorted(w[series][key] for w in windows)
            cells += [c.fmt(vals[0]), c.fmt(vals[len(vals) // 2]), c.fmt(vals[-1])]
        rows.append(cells)
    return c.table(
        [
            "[µs]",
            "run p50",
            "run p99",
            "run p99.9",
            "run max",
            f"p99 of a {label}: lowest",
            "median",
            "highest",
            f"max of a {label}: lowest",
            "median",
            "highest",
        ],
        rows,
    )


def _span(seconds: float) -> str:
    return f"{seconds / 60:g} min" if seconds >= 60 else f"{seconds:g} s"


def plot(data: dict[str, Any], path: Path) -> Path:
    """Memory of both processes, the jitter's tail per window, and the machine's load."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cond = data["conditions"]
    warmup = cond["memory_warmup_s"]
    limit = cond["memory_limit_kb"]
    samples = [s for s in data["memory"]["samples"] if s["phase"] == "loop"]
    windows = data["windows"]
    fig, (ax_mem, ax_jit, ax_lost, ax_load) = plt.subplots(
        4, 1, figsize=(11, 12), sharex=True, gridspec_kw={"height_ratios": [3, 3, 1.3, 1.3]}
    )
    colors = {"supervisor": "tab:blue", "worker": "tab:orange"}
    deviations = [limit]
    for proc, color in colors.items():
        m = data["memory"]["check"].get(proc, {})
        for key, style, width in (("VmRSS", "o-", 1.8), ("RssShmem", ":", 1.2)):
            pts = [(s["t_s"] / 60, s["memory_kb"][proc].get(key)) for s in samples]
            pts = [(t, v) for t, v in pts if v is not None]
            if not pts:
                continue
            base = next((v for t, v in pts if t * 60 >= warmup - 0.5), pts[0][1])
            ys = [v - base for _, v in pts]
            deviations += [abs(y) for (t, _), y in zip(pts, ys, strict=True) if t * 60 >= warmup]
            if key == "VmRSS":
                label = (
                    f"{proc} VmRSS: {pts[0][1] / 1024:.1f} MB at the start, "
                    f"{base / 1024:.1f} MB at {_span(warmup)}, then drift "
                    f"{m.get('drift_kb', 0):+,d} kB, range {m.get('range_kb', 0):,d} kB"
                )
            else:
                if proc == "worker":
                    continue  # locked and mapped at once: flat from the start
                label = f"{proc} shared memory (RssShmem, part of VmRSS)"
            ax_mem.plot([t for t, _ in pts], ys, style, color=color, ms=3, lw=width, label=label)
    span = 1.3 * max(deviations)
    ax_mem.set_ylim(-span, span)
    ax_mem.axhspan(-limit, limit, color="0.92", zorder=0, label=f"±{limit} kB (the check)")
    ax_mem.axvline(warmup / 60, color="0.5", ls="--", lw=1)
    ax_mem.set_ylabel(f"change since {_span(warmup)} [kB]")
    ax_mem.legend(loc="lower right", fontsize=8.5)
    ax_mem.grid(alpha=0.3)
    ax_mem.set_title(
        f"Resident memory, sampled every {_span(cond['sample_s'])} from /proc "
        f"(the first {_span(warmup)} is warm-up; points below the axis are off the scale)",
        fontsize=10,
        loc="left",
    )

    mid = [
        ((w["first_iteration"] + w["last_iteration"] + 1) / 2) / cond["frequency_hz"] / 60
        for w in windows
    ]
    for key, style, label in (("max", "v-", "max"), ("p999", "s-", "p99.9"), ("p99", "o-", "p99")):
        ax_jit.plot(mid, [w["jitter_us"][key] for w in windows], style, ms=3, label=label)
    ax_jit.set_yscale("log")
    ax_jit.axhline(
        1e6 / cond["frequency_hz"], color="tab:red", lw=1, ls=":", label="one period (500 µs)"
    )
    ax_jit.set_ylabel("wake-up jitter [µs]")
    ax_jit.legend(loc="lower right", fontsize=8.5, ncol=4)
    ax_jit.grid(alpha=0.3, which="both")
    ax_jit.set_title(
        f"Wake-up jitter of every iteration, per {_span(cond['window_s'])}: p99, p99.9 "
        "and the maximum",
        fontsize=10,
        loc="left",
    )

    width = cond["window_s"] / 60
    for offset, key, color, label in (
        (-0.2, "messages_missing", "tab:purple", f"messages on {cond['topic']} (channel full)"),
        (0.2, "log_records_missing", "tab:green", "log records (log ring full)"),
    ):
        ax_lost.bar(
            [t + offset * width for t in mid],
            [w.get(key, 0) for w in windows],
            width=0.4 * width,
            color=color,
            label=f"{label}: {sum(w.get(key, 0) for w in windows)} in all",
        )
    ax_lost.set_ylabel("dropped")
    ax_lost.legend(loc="upper left", fontsize=8.5, ncol=2)
    ax_lost.grid(alpha=0.3)
    ax_lost.set_ylim(bottom=0, top=max(1, *(ax_lost.get_ylim()[1:])))
    ax_lost.set_title(
        f"Dropped and counted, per {_span(cond['window_s'])} (delivered + dropped == written)",
        fontsize=10,
        loc="left",
    )

    all_samples = data["memory"]["samples"]
    ts = [s["t_s"] / 60 for s in all_samples]
    ax_load.plot(
        ts, [s["load_avg"][0] for s in all_samples], "k.-", ms=3, label="load average (1 min)"
    )
    ax_load.bar(
        ts,
        [len(s["other_rt_processes"]) for s in all_samples],
        width=0.6 * (ts[1] - ts[0]) if len(ts) > 1 else 0.5,
        color="tab:red",
        alpha=0.45,
        label="others' SCHED_FIFO processes",
    )
    ax_load.set_ylabel("machine")
    ax_load.set_xlabel("minutes since the loop started")
    ax_load.legend(loc="upper left", fontsize=8.5, ncol=2)
    ax_load.grid(alpha=0.3)
    ax_load.set_ylim(bottom=0)
    ax_load.set_title("Other work on the machine (2 cores, shared)", fontsize=10, loc="left")

    m = data["machine"]
    fig.suptitle(
        f"rtcf soak: Fig. 1 + SeqLogger at {cond['frequency_hz']:g} Hz for "
        f"{_span(cond['minutes'] * 60)}, --middleware ros2\n"
        f"{m['cores']} x {m['cpu_model']}, Linux {m['kernel']} ({m['preemption']}), "
        f"{data['timestamp']}",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--minutes",
        type=float,
        default=None,
        help=f"how long the loop runs (default {MINUTES:g}; {QUICK_MINUTES:g} with --quick)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run of about a minute: windows and samples every 5 s; writes "
        "results/soak-quick.json and .png only, leaves the docs alone",
    )
    p.add_argument("--frequency", type=float, default=FREQUENCY, help="loop rate [Hz]")
    p.add_argument(
        "--memory-limit-kb",
        type=int,
        default=MEMORY_LIMIT_KB,
        help=f"largest VmRSS range allowed after the first minute (default {MEMORY_LIMIT_KB})",
    )
    p.add_argument(
        "--replot",
        action="store_true",
        help="run nothing: print, plot and (for the hour) publish the results/soak.json "
        "(soak-quick.json with --quick) of an earlier run",
    )
    args = p.parse_args()
    if args.replot:
        path = c.RESULTS / (f"{NAME}-quick.json" if args.quick else f"{NAME}.json")
        return report(json.loads(path.read_text()), args.quick, write=False)
    c.require_ros2()
    minutes = args.minutes or (QUICK_MINUTES if args.quick else MINUTES)
    window_s = 5.0 if args.quick else 60.0
    sample_s = window_s
    warmup_s = 10.0 if args.quick else 60.0
    duration_s = minutes * 60
    iterations = round(duration_s * args.frequency)
    window = round(window_s * args.frequency)
    machine = c.machine_info()
    domain = os.environ.get("ROS_DOMAIN_ID", "")
    started = time.perf_counter()
    print(
        f"soak: Fig. 1 + SeqLogger at {args.frequency:g} Hz for {minutes:g} min "
        f"({iterations} iterations), {TOPIC} mapped, ROS_DOMAIN_ID {domain or 'unset: 0'}",
        file=sys.stderr,
    )
    logs = LogCounter(window)
    samples: list[dict[str, Any]] = []
    load_before = c.load_avg()
    with c.workdir() as work, c.cpu_dma_latency_zero() as held, c.children() as running:
        counts_file = work / "counts.json"
        launch = work / "soak.launch"
        launch.write_text(soak_launch(counts_file, args.frequency))
        sub = Proc(
            "subscriber",
            [
                sys.executable,
                str(BENCH / "_soak.py"),
                "subscriber",
                "--topic",
                TOPIC,
                "--depth",
                str(QOS_DEPTH),
                "--window",
                str(window),
            ],
        )
        running.append(sub)
        sub.wait_event("ready", 120)
        sup = Proc(
            "supervisor",
            [
                sys.executable,
                str(BENCH / "_soak.py"),
                "supervisor",
                str(launch),
                "--iterations",
                str(iterations),
                "--window",
                str(window),
                "--wait-for-node",
                "rtcf_soak_counter",
            ],
            on_err=logs.line,
        )
        running.append(sup)
        start_event = sup.wait_event("started", 180)
        discovered = sup.event("discovered") or {}
        t0 = start_event["_at"]
        pids: dict[str, int | None] = {
            "supervisor": sup.pid,
            "worker": start_event["worker_pid"],
            "subscriber": sub.pid,
        }
        k = 0
        seen: dict[int, dict[str, Any]] = {}  # other real-time processes since the sample
        ours = {p for p in pids.values() if p} | {os.getpid()}
        next_scan = time.monotonic() + RT_SCAN_S
        while sup.event("result") is None and sup.proc.poll() is None:
            if time.monotonic() >= next_scan:
                for proc in other_rt_processes(ours):
                    seen.setdefault(proc["pid"], proc)
                next_scan += RT_SCAN_S
            due = t0 + k * sample_s
            if due > t0 + duration_s - 1.0:
                time.sleep(0.2)
                continue
            if time.monotonic() >= due:
                samples.append(sample(time.monotonic() - t0, pids, "loop", seen))
                print(
                    f"  {samples[-1]['t_s'] / 60:5.1f} min  VmRSS supervisor "
                    f"{samples[-1]['memory_kb']['supervisor'].get('VmRSS')} kB, worker "
                    f"{samples[-1]['memory_kb']['worker'].get('VmRSS')} kB; "
                    f"log records {logs.delivered}; load {samples[-1]['load_avg'][0]}",
                    file=sys.stderr,
                )
                k += 1
                continue
            time.sleep(min(0.2, max(0.0, due - time.monotonic())))
        if sup.event("result") is not None:
            samples.append(sample(time.monotonic() - t0, pids, "after loop", seen))
        rc = sup.finish(120)
        if rc != 0 or sup.event("result") is None or sup.event("shutdown") is None:
            raise c.BenchmarkError(
                f"the supervisor failed (exit {rc}): "
                + " | ".join(logs.first_other[-3:] + list(logs.last_other)[-3:])
            )
        if not counts_file.exists():
            raise c.BenchmarkError("the SeqLogger wrote no counts (its stop() did not run)")
        counts = json.loads(counts_file.read_text())
        written = int(counts["messages_written"])
        # the subscriber: until it has the last number, or nothing new came for 5 s
        quiet_since, got = time.monotonic(), -1
        give_up = time.monotonic() + 120
        while time.monotonic() < give_up:
            prog = sub.event("progress") or {}
            if prog.get("last", 0) >= written:
                break
            if prog.get("received", 0) != got:
                got, quiet_since = prog.get("received", 0), time.monotonic()
            elif time.monotonic() - quiet_since > 5.0:
                break
            time.sleep(0.2)
        sub.stop()
        final = sub.event("final")
        if final is None:
            raise c.BenchmarkError(f"the subscriber printed no totals: {sub.tail()}")
    load_after = c.load_avg()
    elapsed = time.perf_counter() - started

    result = sup.event("result") or {}
    windows = [
        {k: v for k, v in e.items() if k not in ("event", "_at")} | {"t_s": round(e["_at"] - t0, 2)}
        for e in sup.events
        if e["event"] == "window"
    ]
    received = {int(k): v for k, v in final.get("per_window", {}).items()}
    for w in windows:
        # the window's sequence numbers (the SeqLogger writes one per iteration)
        numbers = min(window, written - w["index"] * window)
        w["log_records_delivered"] = logs.per_window.get(w["index"], 0)
        w["log_records_missing"] = numbers - w["log_records_delivered"]
        w["messages_received"] = received.get(w["index"], 0)
        w["messages_missing"] = numbers - w["messages_received"]
    mem = memory_check(samples, warmup_s, args.memory_limit_kb)
    log_acc = log_check(int(counts["log_records_written"]), result["log_records_dropped"], logs)
    msg_acc = message_check(written, logs, final)
    ovr = overrun_check(result, windows)
    checks = {
        "memory": all(m["ok"] for m in mem.values()),
        "logs": log_acc["ok"],
        "messages": msg_acc["ok"],
        "overruns": ovr["ok"],
        "iterations": result["iterations"] == iterations == int(counts["updates"]),
    }
    enforced = {k: v for k, v in checks.items() if not (args.quick and k == "memory")}
    realtime = start_event.get("realtime", {})
    loop = [s for s in samples if s["phase"] == "loop"]
    span = loop[-1]["t_s"] - loop[0]["t_s"]
    cpu_percent = (
        {proc: 100.0 * (loop[-1]["cpu_s"][proc] - loop[0]["cpu_s"][proc]) / span for proc in pids}
        if span > 0
        else {}
    )
    others = sorted({p["what"] for s in samples for p in s["other_rt_processes"]})
    data: dict[str, Any] = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "machine": machine,
        "conditions": {
            "frequency_hz": args.frequency,
            "minutes": minutes,
            "iterations_planned": iterations,
            "window_s": window_s,
            "sample_s": sample_s,
            "memory_warmup_s": warmup_s,
            "memory_limit_kb": args.memory_limit_kb,
            "topic": TOPIC,
            "qos": {"depth": QOS_DEPTH, "reliability": "reliable", "durability": "transient_local"},
            "ros_domain_id": domain or None,
            "discovery_wait_s": discovered.get("after_s"),
            "cpu_dma_latency_zero": held,
            "realtime": realtime,
            "load_avg_before": load_before,
            "load_avg_after": load_after,
            "load_avg_1min_over_samples": {
                "min": min(s["load_avg"][0] for s in samples),
                "max": max(s["load_avg"][0] for s in samples),
            },
            "other_rt_process_names_seen": others,
            "samples_with_other_rt_processes": sum(1 for s in samples if s["other_rt_processes"]),
            "rt_scan_s": RT_SCAN_S,
            "heartbeat_timeout_s": HEARTBEAT_TIMEOUT_S,
            "cpu_percent_of_one_core": cpu_percent,
            "python": sys.executable,
            "launch_file": launch.name,
        },
        "checks": checks,
        "passed": all(enforced.values()),
        "memory": {"check": mem, "samples": samples},
        "logs": log_acc,
        "messages": msg_acc,
        "overruns": ovr,
        "windows": windows,
        "run": {k: v for k, v in result.items() if k not in ("event", "_at")},
        "component_counts": counts,
        "supervisor_other_lines": {
            "count": logs.other,
            "first": logs.first_other,
            "last": list(logs.last_other),
        },
        "elapsed_s": elapsed,
    }
    return report(data, args.quick)


def report(data: dict[str, Any], quick: bool, *, write: bool = True) -> int:
    """Print the tables and checks, write the JSON, the plot and (full hour) the docs."""
    cond = data["conditions"]
    load = cond["load_avg_1min_over_samples"]
    cpu = cond["cpu_percent_of_one_core"]
    print(f"machine: {c.machine_line(data['machine'])}")
    print(
        f"Fig. 1 + SeqLogger at {cond['frequency_hz']:g} Hz for {cond['minutes']:g} min, "
        f"{cond['topic']} mapped; load average {load['min']:.2f}-{load['max']:.2f}; CPU "
        + ", ".join(f"{k} {v:.0f} %" for k, v in cpu.items())
        + " of a core"
    )
    mem_table = memory_table(data["memory"]["check"], cond["memory_warmup_s"])
    mem_table += "\n\n" + heap_line(data["windows"], cond["memory_warmup_s"])
    acc_table = accounting_table(data["logs"], data["messages"], data["overruns"])
    jit_table = jitter_table(data["run"], data["windows"], cond["window_s"])
    print(mem_table)
    print()
    print(acc_table)
    print()
    print(jit_table)
    for name, ok in data["checks"].items():
        note = " (not enforced with --quick)" if quick and name == "memory" else ""
        print(f"check {name}: {'ok' if ok else 'FAILED'}{note}")
    print(f"total {data['elapsed_s']:.0f} s")
    path = c.RESULTS / (f"{NAME}-quick.json" if quick else f"{NAME}.json")
    if write:
        path = c.write_results(NAME, data, quick)
    png = plot(data, path.with_suffix(".png"))
    print(f"wrote {png.relative_to(c.REPO)}")
    if not quick and cond["minutes"] == MINUTES:
        publish(data, mem_table, acc_table, jit_table)
    return 0 if data["passed"] else 1


def publish(data: dict[str, Any], mem_table: str, acc_table: str, jit_table: str) -> None:
    cond = data["conditions"]
    rt = cond["realtime"]
    sched = rt.get("scheduler", "?")
    applied = [i["name"] for i in rt.get("applied", []) if i.get("ok")]
    load = cond["load_avg_1min_over_samples"]
    cpu = cond["cpu_percent_of_one_core"]
    paragraphs = [
        f"Fig. 1 (H1, F1, R1-R3) plus the SeqLogger at **{cond['frequency_hz']:g} Hz for "
        f"{cond['minutes']:g} minutes** ({cond['iterations_planned']} iterations), "
        f"`--middleware ros2`: the SeqLogger logs `seq N` and writes N on `{cond['topic']}` "
        f"(std_msgs/Int64, reliable, transient local, depth {cond['qos']['depth']}) every "
        f"iteration; records also go to /rosout, iterations to `~/iteration_info`. "
        f"The loop: {sched}, applied: {', '.join(applied)}; `/dev/cpu_dma_latency` held "
        f"at 0. CPU over the run: supervisor {c.fmt(cpu.get('supervisor'), 0)} %, worker "
        f"{c.fmt(cpu.get('worker'), 0)} %, counting subscriber "
        f"{c.fmt(cpu.get('subscriber'), 0)} % of a core. **The machine was shared**: "
        f"load average (1 min) {load['min']:.2f}-{load['max']:.2f} over the samples; "
        f"another process at SCHED_FIFO/RR was running in "
        f"{cond['samples_with_other_rt_processes']} of {len(data['memory']['samples'])} "
        f"samples ({', '.join(cond['other_rt_process_names_seen']) or 'none'}).",
        mem_table,
        acc_table,
        jit_table,
        "![Memory of both processes and tail jitter per minute over the hour]"
        "(../benchmarks/results/soak.png)",
    ]
    c.publish_section(NAME, paragraphs, data["machine"], data["timestamp"])


if __name__ == "__main__":
    c.main_guard(main)
