"""Shared code of the benchmarks: machine, launch files, rtcf, cyclictest, stress-ng, results.

Timing is only ever claimed from these side-by-side runs, never from unit tests: the
machines are shared and noisy, so a number means something only next to a reference
(cyclictest, a plain Python loop) measured in the same run on the same machine.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import importlib.util
import json
import math
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
DOC = REPO / "docs" / "performance.md"

PRIORITY = 80  # SCHED_FIFO priority of the loop, of cyclictest and of the plain loop
RT_CPU = max(0, (os.cpu_count() or 1) - 1)  # the paper's mask 02 on a 2-core machine: CPU 1
APT_PACKAGE = {"cyclictest": "rt-tests", "stress-ng": "stress-ng", "chrt": "util-linux"}
QUANTILES = (("p50", 0.5), ("p99", 0.99), ("p999", 0.999))
COLUMNS = ("min", "p50", "p99", "p999", "max")
LABELS = ("min", "p50", "p99", "p99.9", "max")

# The paper's figures (C++ RTCF on Preempt-RT 5.4.44, i5-8600, 2 kHz, 3 h under stress-ng).
PAPER = {"calc_us": {"p999": 10.3, "max": 18.8}, "jitter_us": {"p999": 1.8, "max": 6.1}}


class BenchmarkError(RuntimeError):
    """A run failed in a way the benchmark cannot recover from (printed as one line)."""


# -- tools and the machine ------------------------------------------------------------


def require_tools(*names: str) -> None:
    """Exit 2 with one line naming the Debian package when a tool is missing."""
    for name in names:
        if shutil.which(name) is None:
            pkg = APT_PACKAGE.get(name, name)
            print(f"{name} is missing: apt-get install -y {pkg}", file=sys.stderr)
            sys.exit(2)


def require_ros2() -> None:
    """Exit 2 with one line where rclpy or std_msgs is missing (not the ROS 2 venv)."""
    for module in ("rclpy", "std_msgs"):
        if importlib.util.find_spec(module) is None:
            print(
                f"{module} is missing: run this with the ROS 2 venv "
                "(.venv-ros2/bin/python; pip install -e '.[ros2]')",
                file=sys.stderr,
            )
            sys.exit(2)


class SpinningNode:
    """An rclpy node of this process, in a context of its own, spun by a thread
    (``start()``) until ``close()``."""

    def __init__(self, name: str) -> None:
        import rclpy

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)

    def start(self) -> None:
        from rclpy.executors import SingleThreadedExecutor

        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except Exception:  # shut down under it
                return

    def close(self) -> None:
        import rclpy

        rclpy.shutdown(context=self.context)
        self.thread.join(5)
        self.node.destroy_node()


def _cpuinfo() -> tuple[str, bool]:
    model, hypervisor = "unknown", False
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and model == "unknown":
                model = line.split(":", 1)[1].strip()
            if line.startswith("flags") and " hypervisor" in line:
                hypervisor = True
    return model, hypervisor


def preemption_model() -> str:
    """PREEMPT_RT, PREEMPT_DYNAMIC, PREEMPT or none, from /sys/kernel/realtime and uname -v."""
    with contextlib.suppress(OSError):
        if Path("/sys/kernel/realtime").read_text().strip() == "1":
            return "PREEMPT_RT"
    version = platform.version()
    for model in ("PREEMPT_RT", "PREEMPT_DYNAMIC", "PREEMPT"):
        if model in version:
            return model
    return "none"


def machine_info() -> dict[str, Any]:
    """What the numbers were measured on (the load average is taken again per condition)."""
    model, hypervisor = _cpuinfo()
    clocksource = "unknown"
    with contextlib.suppress(OSError):
        clocksource = (
            Path("/sys/devices/system/clocksource/clocksource0/current_clocksource")
            .read_text()
            .strip()
        )
    return {
        "cores": os.cpu_count(),
        "cpu_model": model,
        "virtual_machine": hypervisor,
        "kernel": platform.release(),
        "kernel_version": platform.version(),
        "preemption": preemption_model(),
        "clocksource": clocksource,
        "python": platform.python_version(),
        "load_avg": list(os.getloadavg()),
        "rt_cpu": RT_CPU,
    }


def machine_line(m: Mapping[str, Any]) -> str:
    """One line for the docs and the console."""
    vm = ", virtual machine" if m.get("virtual_machine") else ""
    rt = "" if m.get("preemption") == "PREEMPT_RT" else ", not PREEMPT_RT"
    return (
        f"{m['cores']} x {m['cpu_model']}{vm}; Linux {m['kernel']} "
        f"({m['preemption']}{rt}); clocksource {m['clocksource']}; Python {m['python']}"
    )


def steal_ms(cpu: int = RT_CPU) -> float:
    """Time the hypervisor ran something else on ``cpu`` (/proc/stat, 10 ms resolution)."""
    with contextlib.suppress(OSError, IndexError, ValueError):
        for line in Path("/proc/stat").read_text().splitlines():
            fields = line.split()
            if fields[0] == f"cpu{cpu}":
                return int(fields[8]) * 1000 / os.sysconf("SC_CLK_TCK")
    return math.nan


def load_avg() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


# -- quantiles ------------------------------------------------------------------------


def nearest_rank(sorted_values: Sequence[float], q: float) -> float:
    """Nearest-rank quantile (the smallest value v with F(v) >= q), as rtcf computes it."""
    if not sorted_values:
        return math.nan
    rank = max(1, math.ceil(q * len(sorted_values)))
    return float(sorted_values[min(rank, len(sorted_values)) - 1])


def summarize(values_us: Sequence[float]) -> dict[str, float]:
    """min, p50, p99, p99.9, max and mean of samples (already in µs)."""
    s = sorted(values_us)
    if not s:
        return {}
    out = {"min": s[0]}
    for key, q in QUANTILES:
        out[key] = nearest_rank(s, q)
    out["max"] = s[-1]
    out["mean"] = sum(s) / len(s)
    return out


def histogram_quantiles(
    hist: Mapping[int, int], overflows: int, maximum: float
) -> dict[str, float]:
    """Nearest-rank quantiles from a histogram of whole µs; overflowed ranks give the max.

    ``maximum`` is the true maximum the tool reported (it may lie beyond the histogram).
    """
    total = sum(hist.values()) + overflows
    if total == 0:
        return {}
    buckets = sorted((b, c) for b, c in hist.items() if c)
    out: dict[str, float] = {"min": float(buckets[0][0]) if buckets else float(maximum)}
    for key, q in QUANTILES:
        rank = max(1, math.ceil(q * total))
        seen, value = 0, float(maximum)  # past the last bucket: an overflow, report the max
        for bucket, count in buckets:
            seen += count
            if seen >= rank:
                value = float(bucket)
                break
        out[key] = value
    out["max"] = float(maximum)
    out["mean"] = sum(b * c for b, c in buckets) / max(1, total - overflows)
    return out


def merge_ns_histograms(hists: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Quantiles in µs over several of rtcf's ``histograms_ns`` entries, merged.

    Buckets are given by their lower bound (relative width 1/sub_buckets, under 1 %);
    a quantile is the lower bound of the bucket holding its rank; min and max are exact.
    """
    counts: dict[int, int] = {}
    for h in hists:
        for lower, n in h["buckets"]:
            counts[int(lower)] = counts.get(int(lower), 0) + int(n)
    total = sum(counts.values())
    if total == 0:
        return {}
    ordered = sorted(counts.items())
    out = {"min": min(h["min"] for h in hists) / 1e3}
    for key, q in QUANTILES:
        rank, seen = max(1, math.ceil(q * total)), 0
        for lower, n in ordered:
            seen += n
            if seen >= rank:
                out[key] = lower / 1e3
                break
    out["max"] = max(h["max"] for h in hists) / 1e3
    out["mean"] = sum(h["sum"] for h in hists) / total / 1e3
    return out


def count_above(hist: Mapping[str, Any], threshold_ns: int) -> int:
    """Samples of one of rtcf's ``histograms_ns`` entries in buckets at or above a bound."""
    return sum(int(n) for lower, n in hist["buckets"] if int(lower) >= threshold_ns)


def ratio(a: float | None, b: float | None) -> float:
    if a is None or b is None or b <= 0 or math.isnan(a) or math.isnan(b):
        return math.nan
    return a / b


# -- launch files -----------------------------------------------------------------------


@dataclass
class Node:
    """One rt_launcher node: ``args="MODULE Class"``, its remaps and raw rosparam texts."""

    name: str
    module: str
    cls: str
    remaps: list[tuple[str, str]] = field(default_factory=list)
    params: dict[str, str] = field(default_factory=dict)


def paper_launch_path() -> Path:
    return Path(str(resources.files("rtcf_examples") / "launch" / "paper_evaluation.launch"))


def fig1_nodes() -> list[Node]:
    """The components of Fig. 1, read from the packaged paper_evaluation.launch.

    Read rather than copied, so the benchmarks run exactly the wiring the example ships.
    """
    root = ET.parse(paper_launch_path()).getroot()
    nodes = []
    for el in root.iter("node"):
        if el.get("type") != "rt_launcher":
            continue
        module, cls = (el.get("args") or "").split()[:2]
        nodes.append(
            Node(
                name=el.get("name", ""),
                module=module,
                cls=cls,
                remaps=[(r.get("from", ""), r.get("to", "")) for r in el.iter("remap")],
                params={p.get("param", ""): (p.text or "").strip() for p in el.iter("rosparam")},
            )
        )
    if not nodes:
        raise BenchmarkError(f"{paper_launch_path()} has no rt_launcher node")
    return nodes


def launch_xml(
    nodes: Sequence[Node],
    *,
    frequency: float,
    cpu: int = RT_CPU,
    priority: int = PRIORITY,
    lock_memory: bool = True,
    wait_policy: str = "absolute",
    runner_params: Mapping[str, str] | None = None,
) -> str:
    """A ROS 1 launch file with one rt_runner and the given rt_launcher nodes.

    ``runner_params``: more rt_runner parameters, as raw rosparam texts.
    """
    lines = [
        "<launch>",
        '    <node name="rt_runner" pkg="rtcf" type="rt_runner" output="screen">',
        '        <rosparam param="mode">"no_wait"</rosparam>',
        f'        <rosparam param="frequency">{float(frequency)}</rosparam>',
        f'        <rosparam param="wait_policy">"{wait_policy}"</rosparam>',
        f'        <rosparam param="priority">{priority}</rosparam>',
        f'        <rosparam param="lock_memory">{lock_memory}</rosparam>',
        f'        <rosparam param="cpu_affinity_mask">{1 << cpu}</rosparam>',
        *(
            f'        <rosparam param="{k}">{v}</rosparam>'
            for k, v in (runner_params or {}).items()
        ),
        "    </node>",
    ]
    for n in nodes:
        lines.append(
            f'    <node name="{n.name}" pkg="rtcf" type="rt_launcher" args="{n.module} {n.cls}">'
        )
        lines.extend(f'        <remap from="{a}" to="{b}"/>' for a, b in n.remaps)
        lines.extend(f'        <rosparam param="{k}">{v}</rosparam>' for k, v in n.params.items())
        lines.append("    </node>")
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


# -- running rtcf -----------------------------------------------------------------------


@dataclass
class RtcfRun:
    """One ``rtcf launch`` run: its timing.json and how long the launch took."""

    timing: dict[str, Any]
    command: list[str]
    total_wall_s: float
    setup_s: float  # wall time from spawning the CLI until the loop started (upper bound)
    setup_source: str  # how setup_s was found
    stdout: str
    stderr: str
    wrapper: list[str]
    steal_ms: float  # hypervisor steal time on the loop's CPU during the whole run


_RAN = re.compile(r"^ran \d+ iterations")
_STARTED = re.compile(r"^rtcf: real-time:")
_wrapper_cache: list[str] | None = None


def _reader(stream: Any, sink: list[tuple[float, str]]) -> None:
    for line in iter(stream.readline, ""):
        sink.append((time.perf_counter(), line))
    stream.close()


def rtcf_command(*args: object) -> list[str]:
    """``python -m rtcf ARGS``, with this interpreter."""
    return [sys.executable, "-m", "rtcf", *map(str, args)]


def stop_process(proc: subprocess.Popen[Any], grace_s: float = 5.0) -> None:
    """Terminate a child we started (SIGTERM, then SIGKILL), by its own id."""
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(grace_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


class ChildProcess:
    """A child process whose stdout and stderr are read while it runs, each by a thread
    of its own: the subclass's ``_read_out`` and ``_read_err``, which notify ``_cond``.
    Set what they fill before calling this ``__init__``: they start reading in it."""

    def __init__(self, label: str, cmd: Sequence[str], env: Mapping[str, str]) -> None:
        self.label = label
        self.cmd = list(cmd)
        self._cond = threading.Condition()
        self.proc = subprocess.Popen(
            self.cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            env=dict(env),
            cwd=REPO,
        )
        self._threads = [
            threading.Thread(target=self._read_out, daemon=True),
            threading.Thread(target=self._read_err, daemon=True),
        ]
        for t in self._threads:
            t.start()

    def _read_out(self) -> None:
        raise NotImplementedError

    def _read_err(self) -> None:
        raise NotImplementedError

    @property
    def pid(self) -> int:
        return self.proc.pid

    def finish(self, timeout: float, join_s: float = 5.0) -> int:
        """Wait for the end by itself; BenchmarkError if it takes longer."""
        try:
            rc = self.proc.wait(timeout)
        except subprocess.TimeoutExpired as exc:
            raise BenchmarkError(f"{self.label} did not end in {timeout:g} s") from exc
        for t in self._threads:
            t.join(join_s)
        return rc

    def stop(self, grace_s: float = 10.0) -> int | None:
        """SIGINT (Ctrl-C: rtcf writes its report), then SIGTERM, then SIGKILL."""
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                stop_process(self.proc)
        for t in self._threads:
            t.join(5)
        return self.proc.returncode


@contextlib.contextmanager
def children() -> Iterator[list[Any]]:
    """Every ChildProcess appended to the yielded list is stopped on leaving, whatever
    happens."""
    started: list[Any] = []
    try:
        yield started
    finally:
        for child in reversed(started):
            with contextlib.suppress(Exception):
                child.stop()


def run_rtcf(
    launch: Path,
    duration_s: float,
    report_dir: Path,
    *,
    wrapper: Sequence[str] = (),
    extra_args: Sequence[str] = (),
    timeout_s: float | None = None,
    env: Mapping[str, str] | None = None,
) -> RtcfRun:
    """Run ``rtcf launch LAUNCH --duration D --report DIR`` and read DIR/timing.json.

    ``env``: variables set for rtcf on top of this process's environment.
    """
    cmd = [*wrapper, *rtcf_command("launch", launch, *extra_args, "--duration",
                                   f"{duration_s:g}", "--report", report_dir)]
    out: list[tuple[float, str]] = []
    err: list[tuple[float, str]] = []
    steal0 = steal_ms()
    started = time.perf_counter()
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env={**os.environ, **env} if env else None,
    )
    readers = [
        threading.Thread(target=_reader, args=(proc.stdout, out), daemon=True),
        threading.Thread(target=_reader, args=(proc.stderr, err), daemon=True),
    ]
    for t in readers:
        t.start()
    try:
        rc = proc.wait(timeout_s if timeout_s is not None else duration_s * 3 + 120)
    except subprocess.TimeoutExpired as exc:
        raise BenchmarkError(f"rtcf did not finish in time: {' '.join(cmd)}") from exc
    finally:
        stop_process(proc)
        for t in readers:
            t.join(5)
    total = time.perf_counter() - started
    stdout = "".join(line for _, line in out)
    stderr = "".join(line for _, line in err)
    path = report_dir / "timing.json"
    if rc != 0 or not path.exists():
        tail = " | ".join(stderr.strip().splitlines()[-3:])
        raise BenchmarkError(f"rtcf launch failed (exit {rc}): {tail or 'no output'}")
    timing = json.loads(path.read_text())
    # Two upper bounds of the time until the first iteration, the tighter one wins: rtcf
    # prints 'real-time:' once the worker has said it starts the loop (the supervisor may
    # print it late), and prints 'ran N iterations' after the loop, which took loop_s.
    loop_s = float(timing.get("duration_s") or duration_s)
    bounds = {"total wall time minus the loop's duration": total - loop_s}
    first_rt = next((t for t, line in err if _STARTED.search(line)), None)
    if first_rt is not None:
        bounds["wall time until the CLI printed 'real-time:'"] = first_rt - started
    ran = next((t for t, line in err + out if _RAN.search(line)), None)
    if ran is not None:
        bounds["wall time until the CLI printed 'ran N iterations', minus the loop's duration"] = (
            ran - started - loop_s
        )
    source, setup = min(bounds.items(), key=lambda kv: kv[1])
    steal = steal_ms() - steal0
    return RtcfRun(timing, cmd, total, setup, source, stdout, stderr, list(wrapper), steal)


def is_fifo(timing: Mapping[str, Any]) -> bool:
    return "FIFO" in str(timing.get("realtime", {}).get("scheduler", ""))


def rt_wrapper(allow: bool, workdir: Path) -> list[str]:
    """``chrt``/``taskset`` for rtcf if, and only if, rtcf does not apply SCHED_FIFO itself.

    A short probe run asks rtcf (timing.json's ``realtime.scheduler``). Comparing a
    normally scheduled loop against cyclictest at SCHED_FIFO 80 would measure the
    scheduler, not rtcf; the wrapper gives both the same priority and CPU (it cannot
    give rtcf mlockall). ``--no-rt-wrapper`` measures rtcf exactly as it runs itself.
    """
    global _wrapper_cache
    if _wrapper_cache is not None:
        return _wrapper_cache
    if not allow:
        _wrapper_cache = []
        return _wrapper_cache
    probe = workdir / "probe.launch"
    probe.write_text(launch_xml(fig1_nodes(), frequency=1000.0))
    run = run_rtcf(probe, 0.02, workdir / "probe")
    if is_fifo(run.timing):
        _wrapper_cache = []
    else:
        require_tools("chrt", "taskset")
        _wrapper_cache = ["chrt", "-f", str(PRIORITY), "taskset", "-c", str(RT_CPU)]
        sched = run.timing.get("realtime", {}).get("scheduler")
        print(
            f"note: rtcf reports scheduler {sched}; running it under "
            f"'{' '.join(_wrapper_cache)}' so it gets the same priority and CPU as the "
            "references (no mlockall); --no-rt-wrapper to measure it as it is",
            file=sys.stderr,
        )
    return _wrapper_cache


# rtcf's two hot paths (docs/performance.md#the-hot-path-in-c): the environment that
# picks each, and what timing.json's realtime.hot_path.path then says
HOT_PATHS = {
    "compiled": ({"RTCF_PURE_PYTHON": "0"}, "compiled"),
    "pure": ({"RTCF_PURE_PYTHON": "1"}, "Python"),
}
HOT_PATH_LABELS = {"compiled": "compiled hot path", "pure": "pure Python hot path"}
# the compiled path with each component timed by clock_gettime, not by the TSC (where
# the kernel's clocksource is the TSC, rtcf reads it instead: 10 ns against 25 ns)
CLOCK_GETTIME = "compiled_clock_gettime"
HOT_PATH_VARIANTS = {
    **HOT_PATHS,
    CLOCK_GETTIME: ({"RTCF_PURE_PYTHON": "0", "RTCF_COMPONENT_CLOCK": "monotonic"}, "compiled"),
}


def run_rtcf_on(hot_path: str, launch: Path, duration_s: float, report_dir: Path,
                **kwargs: Any) -> RtcfRun:
    """:func:`run_rtcf` on one hot path (``compiled`` or ``pure``); a BenchmarkError if
    rtcf ran the other one (the comparison would be wrong)."""
    env, expected = HOT_PATH_VARIANTS[hot_path]
    run = run_rtcf(launch, duration_s, report_dir, env=env, **kwargs)
    hot = run.timing.get("realtime", {}).get("hot_path", {})
    if hot.get("path") != expected:
        raise BenchmarkError(
            f"rtcf ran its hot path {hot.get('path')!r} ({hot.get('why') or 'no reason given'}), "
            f"not {expected!r}"
        )
    if hot_path == CLOCK_GETTIME and hot.get("component_clock") != "CLOCK_MONOTONIC":
        raise BenchmarkError(f"rtcf timed its components by {hot.get('component_clock')!r}, "
                             "not by clock_gettime")
    return run


def against_plain(rt: Mapping[str, Any], plain_rt: Mapping[str, Any], plain: str) -> str:
    """How rtcf (``rt``: its realtime conditions) and the ``plain`` reference ran, for
    the docs' sections."""
    return (
        f"rtcf reported scheduler {rt.get('scheduler')}, mlockall {rt.get('mlockall')}"
        + (f", run under `{rt['wrapper']}`" if rt.get("wrapper") else "")
        + f"; {plain}: {plain_rt['scheduler']} {plain_rt['priority']}, "
        f"mlockall {plain_rt['mlockall']}, CPUs {plain_rt['cpu_affinity']}"
    )


def rt_conditions(run: RtcfRun) -> dict[str, Any]:
    """The realtime section of timing.json plus what the benchmark added."""
    rt = dict(run.timing.get("realtime", {}))
    rt["wrapper"] = " ".join(run.wrapper) or None
    rt["steal_ms"] = run.steal_ms
    return rt


# -- cyclictest -------------------------------------------------------------------------


def run_cyclictest(
    duration_s: float,
    *,
    interval_us: int = 500,
    priority: int = PRIORITY,
    cpu: int = RT_CPU,
    max_us: int = 10_000,
) -> dict[str, Any]:
    """cyclictest in histogram mode (one thread, same priority and CPU as the loop).

    Returns its latency quantiles (nearest rank over the histogram, 1 µs buckets),
    the true min/max it reports, overflow count and the non-empty buckets.
    """
    loops = max(1, round(duration_s * 1e6 / interval_us))
    cmd = [
        "cyclictest",
        "-m",
        f"-p{priority}",
        f"-i{interval_us}",
        "-l",
        str(loops),
        "-a",
        str(cpu),
        "-q",
        "-h",
        str(max_us),
    ]
    steal0 = steal_ms(cpu)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        stdout, stderr = proc.communicate(timeout=duration_s * 3 + 60)
    except subprocess.TimeoutExpired as exc:
        raise BenchmarkError(f"cyclictest did not finish in time: {' '.join(cmd)}") from exc
    finally:
        stop_process(proc)
    if proc.returncode != 0:
        raise BenchmarkError(f"cyclictest failed (exit {proc.returncode}): {stderr.strip()}")
    hist: dict[int, int] = {}
    info: dict[str, int] = {}
    for line in stdout.splitlines():
        m = re.match(r"^(\d+)\s+(\d+)\s*$", line)
        if m:
            if int(m.group(2)):
                hist[int(m.group(1))] = int(m.group(2))
            continue
        m = re.match(r"^# (Total|Min Latencies|Max Latencies|Histogram Overflows):\s*(\d+)", line)
        if m:
            info[m.group(1)] = int(m.group(2))
    if not hist and not info.get("Histogram Overflows"):
        raise BenchmarkError(f"cyclictest printed no histogram: {stdout[:200]!r}")
    overflows = info.get("Histogram Overflows", 0)
    maximum = info.get("Max Latencies", max(hist) if hist else max_us)
    stats = histogram_quantiles(hist, overflows, maximum)
    if "Min Latencies" in info:
        stats["min"] = float(info["Min Latencies"])
    return {
        "command": " ".join(cmd),
        "loops": loops,
        "samples": sum(hist.values()) + overflows,
        "overflows": overflows,
        "steal_ms": steal_ms(cpu) - steal0,
        "latency_us": stats,
        "histogram": {str(k): v for k, v in sorted(hist.items())},
    }


# -- power management -----------------------------------------------------------------


@contextlib.contextmanager
def cpu_dma_latency_zero() -> Iterator[bool]:
    """Hold ``/dev/cpu_dma_latency`` at 0 µs (no deep idle states) while inside.

    cyclictest does this by itself for as long as it runs; rtcf and the plain loop do
    not. Measured on the 2-core VM (cpuidle haltpoll): it alone takes the median
    wake-up latency of all three from about 25 µs to 15 µs. Held for every run of a
    condition, so the references and rtcf see the same machine. Yields whether it held.
    """
    try:
        fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
    except OSError:
        yield False
        return
    try:
        os.write(fd, (0).to_bytes(4, sys.byteorder, signed=True))
        yield True
    finally:
        os.close(fd)


# -- stress-ng --------------------------------------------------------------------------


def stress_args(per_core_cpu: int = 8, per_core_io: int = 8) -> list[str]:
    """The paper's ``--cpu 48 --io 48`` on 6 cores, scaled to this machine's cores."""
    cores = os.cpu_count() or 1
    return ["--cpu", str(per_core_cpu * cores), "--io", str(per_core_io * cores)]


@contextlib.contextmanager
def stress(timeout_s: float, warmup_s: float = 2.0) -> Iterator[dict[str, Any]]:
    """Run stress-ng in the background; always stopped on leaving (Ctrl-C included).

    ``--timeout`` makes it end by itself even if this process is killed outright.
    It gets its own process group so that its workers are stopped with it.
    """
    cmd = ["stress-ng", *stress_args(), "--timeout", f"{math.ceil(timeout_s)}s", "--quiet"]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )
    info: dict[str, Any] = {"command": " ".join(cmd)}
    try:
        time.sleep(warmup_s)
        if proc.poll() is not None:
            raise BenchmarkError(f"stress-ng exited early: {proc.stderr.read().decode()[:200]}")  # type: ignore[union-attr]
        yield info
        info["still_running_at_end"] = proc.poll() is None
    finally:
        if proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        if proc.stderr is not None:
            proc.stderr.close()


# -- command line, results, docs -----------------------------------------------------


def parser(description: str, default_duration: float) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help=f"seconds per run (default {default_duration:g}; 2 with --quick)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run of a few seconds: prints and writes results/<name>-quick.json only",
    )
    p.add_argument(
        "--no-rt-wrapper",
        action="store_true",
        help="never run rtcf under chrt/taskset, even if it reports normal scheduling",
    )
    return p


def now_iso() -> str:
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()


def print_report(machine: Mapping[str, Any], elapsed_s: float, *lines: str) -> None:
    """The console's report of a run: the machine, ``lines`` (tables, verdicts; "" for a
    blank line), and how long the whole benchmark took."""
    print(f"machine: {machine_line(machine)}")
    for line in lines:
        print(line)
    print(f"total {elapsed_s:.0f} s")


def write_results(
    name: str, data: Mapping[str, Any], quick: bool, docs: Sequence[str] = ()
) -> Path:
    """Write ``results/NAME.json`` (``NAME-quick.json`` with --quick) and say so; without
    --quick, ``docs`` (paragraphs, if any) become the section NAME of docs/performance.md,
    under ``data``'s machine and timestamp."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / (f"{name}-quick.json" if quick else f"{name}.json")
    text = json.dumps(data, indent=2, default=_json_default)
    # lists of numbers, and lists of such pairs (histogram buckets), on one line each
    text = _NUMBER_LIST.sub(
        lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]", text
    )
    text = _PAIR_LIST.sub(lambda m: "[" + ", ".join(_PAIR.findall(m.group(0))) + "]", text)
    path.write_text(text + "\n")
    print(f"wrote {path.relative_to(REPO)}")
    if docs and not quick:
        publish_section(name, docs, data["machine"], data["timestamp"])
    return path


_NUMBER_LIST = re.compile(r"\[\s*((?:-?[\d.eE+-]+,?\s*)+)\]")
_PAIR = re.compile(r"\[[^\[\]]*\]")
_PAIR_LIST = re.compile(r"\[\s*(?:\[[-\d.eE+, ]*\],?\s*)+\]")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} to JSON")


def publish_section(
    name: str, paragraphs: Sequence[str], machine: Mapping[str, Any], timestamp: str
) -> None:
    """Rewrite a benchmark's section of docs/performance.md: the paragraphs (text,
    tables, the verdict), a blank line apart, ending with where and when."""
    footer = (
        f"Machine: {machine_line(machine)}. Measured {timestamp} "
        f"(`benchmarks/results/{name}.json`)."
    )
    body = "\n\n".join(paragraphs)
    update_doc_section(name, f"{body.rstrip()}\n\n{footer}")
    print(f"updated {DOC.relative_to(REPO)} (section {name})")


def update_doc_section(name: str, body: str) -> None:
    """Replace the text between ``<!-- BEGIN name -->`` and ``<!-- END name -->``."""
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    text = DOC.read_text() if DOC.exists() else "# Performance\n"
    block = f"{begin}\n{body.strip()}\n{end}"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: block, text)
    else:
        text = text.rstrip() + f"\n\n{block}\n"
    DOC.write_text(text)


def fmt(x: float | None, digits: int = 1) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return f"{x:.{digits}f}"


def fmt_ratio(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.2f}x"


def table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A markdown table (also readable on the console)."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"

    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([line(headers), sep, *(line(r) for r in rows)])


def stat_cells(stats: Mapping[str, float | None], keys: Sequence[str] = COLUMNS) -> list[str]:
    return [fmt(stats.get(k)) for k in keys]


@contextlib.contextmanager
def workdir() -> Iterator[Path]:
    """A temporary directory for generated launch files and reports."""
    with tempfile.TemporaryDirectory(prefix="rtcf-bench-") as d:
        yield Path(d)


def main_guard(fn: Any) -> None:
    """Run ``fn()``; a BenchmarkError ends with one line and exit 1, Ctrl-C with 130.

    SIGTERM is turned into KeyboardInterrupt so that the finally blocks stop stress-ng
    and the other children on it too.
    """

    def terminate(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, terminate)
    try:
        sys.exit(fn())
    except BenchmarkError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(1)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)


class NoSleepClock:
    """The system clock without the sleep: an executor runs iterations back to back
    (the tight loops: the caches stay warm)."""

    simulated = False

    def __init__(self) -> None:
        self.now_ns = time.monotonic_ns

    def sleep_until_ns(self, deadline_ns: int) -> None:
        pass


def run_reference(script: str, frequency: float, duration: float, *extra: str) -> dict[str, Any]:
    """A plain Python reference loop (``_plain_loop.py``, ``_plain_chain.py``) in its own
    process, at the priority and on the CPU rtcf's loop gets; its JSON, with the command
    and the steal time on that CPU during the run."""
    cmd = [
        sys.executable, str(REPO / "benchmarks" / script), "--frequency", str(frequency),
        "--duration", f"{duration:g}", "--cpu", str(RT_CPU), "--priority", str(PRIORITY),
        *extra,
    ]
    steal0 = steal_ms()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=duration * 3 + 60)
    finally:
        stop_process(proc)
    if proc.returncode != 0:
        raise BenchmarkError(f"{script} failed (exit {proc.returncode}): {err.strip()}")
    data: dict[str, Any] = json.loads(out)
    data["command"] = " ".join(cmd)
    data["steal_ms"] = steal_ms() - steal0
    return data


def best_ns_per_iteration(fn: Any, n: int, repeats: int) -> float:
    """timeit's convention: the best of ``repeats`` runs is the least disturbed one."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        fn(n)
        best = min(best, (time.perf_counter_ns() - t0) / n)
    return best
