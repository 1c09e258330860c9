"""End-to-end latency through ROS 2: Fig. 1 the ROS-only way against rtcf, side by side.

The same five-stage architecture (Fig. 1: H1 -> F1, R1 -> R2 -> R3, with R1's and R3's
loops back into H1) runs three ways, one after the other in alternating rounds, at the
same loop rate, for the same time, under the same probe:

* **rtcf**: ``rtcf launch --middleware ros2``, the five stages as components of one
  loop (``_latency_components.Stage``), only H1's input and R3's output mapped to ROS 2
  topics (``ros_mapping_whitelist``); the loop runs as its launch file says
  (SCHED_FIFO 80 on one CPU, memory locked, as the paper's launch file).
* **ROS-only, timers**: five rclpy nodes, one process each (as ``ros2 run`` starts
  them), linked by topics; each keeps the latest value of its inputs and publishes
  from a timer at the loop rate (``_ros_only_node.py``).
* **ROS-only, subscription-driven**: the same nodes publishing from their
  subscription callbacks, no timers.

Every stage outputs the smallest of its forward inputs, so the output is the input's
sequence number once that number has come through every path. The probe
(``_latency_probe.py``, rclpy) publishes the numbers at ``--rate`` on average, at
random intervals (so that they meet the periodic systems at every phase of their
period), and times the first output carrying each: end-to-end latency, its
quantiles, lost numbers, and the jitter of the output arrival intervals (minus the
send intervals); and the CPU time each system takes, with the probe's messages and,
before the probe starts, without any. The probe, the rtcf supervisor
(which holds the ROS 2 bridge thread; rtcf keeps it off the loop's CPU) and the
ROS-only nodes run at normal scheduling. A fourth system, one rclpy node echoing the
input at once, is the floor of two rclpy hops.

The default 500 Hz is the highest rate at which the five ROS-only timer nodes keep
their rate on the 2-core machine the docs were measured on (see docs/performance.md).

``--deadline S`` gives rtcf's mapped input (H1's ``in1``, the probe's topic) an input
deadline of S seconds (``deadline/in1``, ``on_deadline`` continue): such an input takes
the same way into the loop as one without (results beside, docs left alone).

    .venv-ros2/bin/python benchmarks/ros2_latency.py [--duration S] [--rounds N]
        [--frequency HZ] [--rate HZ] [--deadline S] [--quick]
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import _common as c
import _hosts

NAME = "ros2_latency"
BENCH = Path(__file__).resolve().parent
SRC = c.REPO / "src"
FREQUENCY = 500.0  # the loop rate of every system (see --frequency and the docs)
RATE = 200.0  # probe messages per second
DURATION = 40.0  # seconds per system
ROUNDS = 4

# Fig. 1 with a number carried through: (stage, forward inputs, loops back into it).
# A stage publishes on its own name; R3 on the output topic ("out"), the probe on "in".
FIG1: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    ("H1", ("in",), ("R1", "out")),
    ("F1", ("H1",), ()),
    ("R1", ("H1",), ()),
    ("R2", ("F1", "H1", "R1"), ()),
    ("R3", ("F1", "R2"), ()),
)
# The floor of any rclpy system: one node that republishes every input message at once.
ECHO: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (("echo", ("in",), ()),)
OUTPUT_OF = {"R3": "out", "echo": "out"}

SYSTEMS = ("rtcf", "ros_timer", "ros_event", "ros_echo")
LABEL = {
    "rtcf": "rtcf: 5 components, 1 loop, in + out mapped",
    "ros_timer": "ROS-only: 5 nodes, timers",
    "ros_event": "ROS-only: 5 nodes, subscription-driven",
    "ros_echo": "reference: 1 rclpy node echoing",
}
PERIODIC = ("rtcf", "ros_timer")  # they publish their output once per loop period
ROS_ONLY = {"ros_timer": (FIG1, "timer"), "ros_event": (FIG1, "event"), "ros_echo": (ECHO, "event")}


# -- child processes ------------------------------------------------------------------


class Child(c.ChildProcess):
    """A child process whose stdout and stderr lines are collected while it runs."""

    def __init__(self, label: str, cmd: Sequence[str], env: Mapping[str, str]) -> None:
        self.stdout: list[str] = []
        self.stderr: list[str] = []
        super().__init__(label, cmd, env)

    def _read_out(self) -> None:
        self._read(self.proc.stdout, self.stdout)

    def _read_err(self) -> None:
        self._read(self.proc.stderr, self.stderr)

    def _read(self, stream: Any, sink: list[str]) -> None:
        for line in iter(stream.readline, ""):
            with self._cond:
                sink.append(line)
                self._cond.notify_all()
        stream.close()
        with self._cond:
            self._cond.notify_all()

    def tail(self, n: int = 3) -> str:
        lines = [ln.strip() for ln in self.stderr if ln.strip()]
        return " | ".join(lines[-n:]) or "no output"

    def wait_for(self, text: str, timeout: float) -> None:
        """Until a line of stdout or stderr contains ``text``; BenchmarkError otherwise."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                if any(text in ln for ln in self.stdout + self.stderr):
                    return
                if self.proc.poll() is not None and not any(t.is_alive() for t in self._threads):
                    raise c.BenchmarkError(
                        f"{self.label} ended (exit {self.proc.returncode}) before "
                        f"saying {text!r}: {self.tail()}"
                    )
                left = deadline - time.monotonic()
                if left <= 0:
                    raise c.BenchmarkError(
                        f"{self.label} did not say {text!r} in {timeout:g} s: {self.tail()}"
                    )
                self._cond.wait(min(left, 0.2))


# --hosts 2: the system runs on one "host" and the probe on another (network namespaces
# joined by a veth pair, benchmarks/_hosts.py); each role's command prefix, and the
# environment that keeps Fast DDS on UDP (set by main)
PLACE: dict[str, list[str]] = {"system": [], "probe": []}
HOST_ENV: dict[str, str] = {}


def child_env() -> dict[str, str]:
    """The repository's src and benchmarks first on the path; ROS_DOMAIN_ID inherited."""
    env = dict(os.environ) | HOST_ENV
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(SRC), str(BENCH), env.get("PYTHONPATH", "")) if p
    )
    return env


# -- CPU time and scheduling of a process tree ------------------------------------------


def _descendants(pid: int) -> list[int]:
    out = [pid]
    with contextlib.suppress(OSError):
        for task in Path(f"/proc/{pid}/task").iterdir():
            with contextlib.suppress(OSError):
                for child in (task / "children").read_text().split():
                    out.extend(_descendants(int(child)))
    return out


def cpu_seconds(pid: int) -> float:
    """User plus system time of one process (all its threads) so far."""
    with contextlib.suppress(OSError, IndexError, ValueError):
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return 0.0


def sched_of(pid: int) -> str:
    """The scheduling policy, priority and CPUs of a process's main thread."""
    names = {os.SCHED_OTHER: "SCHED_OTHER", os.SCHED_FIFO: "SCHED_FIFO", os.SCHED_RR: "SCHED_RR"}
    try:
        policy = os.sched_getscheduler(pid)
        prio = os.sched_getparam(pid).sched_priority
        cpus = sorted(os.sched_getaffinity(pid))
    except OSError:
        return "gone"
    name = names.get(policy, str(policy))
    where = "any CPU" if len(cpus) == os.cpu_count() else f"CPUs {cpus}"
    return f"{name}{f' {prio}' if prio else ''}, {where}"


def fifo_threads(pid: int) -> str:
    """The SCHED_FIFO threads of a process (the bridge's publishing thread), or none."""
    found = []
    with contextlib.suppress(OSError):
        for task in Path(f"/proc/{pid}/task").iterdir():
            with contextlib.suppress(OSError):
                if os.sched_getscheduler(int(task.name)) == os.SCHED_FIFO:
                    found.append(f"SCHED_FIFO {os.sched_getparam(int(task.name)).sched_priority}")
    return ", ".join(found) or "none at SCHED_FIFO"


# -- the systems ----------------------------------------------------------------------


def topic(prefix: str, name: str) -> str:
    return f"{prefix}/{OUTPUT_OF.get(name, name)}"


def rtcf_launch(prefix: str, frequency: float, deadline: float = 0.0) -> str:
    """Fig. 1 of Stage components; only the probe's two topics map to ROS 2 (the input
    with a ``deadline`` if one is given)."""
    nodes = []
    for name, forward, feedback in FIG1:
        remaps = [(f"in{i}", topic(prefix, t)) for i, t in enumerate(forward, 1)]
        remaps += [(f"fb{i}", topic(prefix, t)) for i, t in enumerate(feedback, 1)]
        remaps.append(("out", topic(prefix, name)))
        params = {"is_first": "True"} if name == FIG1[0][0] else {}
        if name == FIG1[0][0] and deadline > 0:
            params["deadline/in1"] = f"{deadline:g}"
        nodes.append(c.Node(name, "_latency_components", "Stage", remaps, params))
    whitelist = f"{prefix}/(in|out)"
    return c.launch_xml(
        nodes,
        frequency=frequency,
        runner_params={"ros_mapping_whitelist": f'"{whitelist}"'},
    )


def start_rtcf(
    launch: Path, report: Path, wrapper: Sequence[str], started: list[Child]
) -> list[Child]:
    cmd = [*PLACE["system"], *wrapper, *c.rtcf_command(
        "launch", launch, "--middleware", "ros2", "--quiet", "--report", report)]
    child = Child("rtcf launch", cmd, child_env())
    started.append(child)
    child.wait_for("running until Ctrl-C", 60)
    return [child]


def start_ros_only(prefix: str, system: str, frequency: float, started: list[Child]) -> list[Child]:
    stages, mode = ROS_ONLY[system]
    nodes = []
    for name, forward, feedback in stages:
        cmd = [
            *PLACE["system"],
            sys.executable,
            str(BENCH / "_ros_only_node.py"),
            "--name",
            f"{name}_{system}",
            "--inputs",
            ",".join(topic(prefix, t) for t in forward),
            "--feedback",
            ",".join(topic(prefix, t) for t in feedback),
            "--output",
            topic(prefix, name),
            "--rate",
            f"{frequency:g}",
            "--mode",
            mode,
        ]
        child = Child(f"ROS-only node {name}", cmd, child_env())
        started.append(child)
        nodes.append(child)
    for child in nodes:
        child.wait_for("ready", 60)
    return nodes


def run_round(
    system: str,
    args: Any,
    work: Path,
    tag: str,
    wrapper: Sequence[str],
) -> dict[str, Any]:
    """One system for one round: start it, probe it, stop it."""
    prefix = f"/latency_{system}"
    result: dict[str, Any] = {"system": system}
    with c.children() as started:
        if system == "rtcf":
            launch = work / "fig1_latency.launch"
            launch.write_text(rtcf_launch(prefix, args.frequency, args.deadline))
            report = work / f"report-{tag}"
            system_procs = start_rtcf(launch, report, wrapper, started)
            supervisor, *worker = _descendants(system_procs[0].pid)
            procs = {"supervisor (ROS 2 bridge thread)": [supervisor], "worker (loop)": worker}
        else:
            system_procs = start_ros_only(prefix, system, args.frequency, started)
            procs = {p.label.rsplit(" ", 1)[-1]: [p.pid] for p in system_procs}

        def cpu_now() -> dict[str, float]:
            return {k: sum(map(cpu_seconds, v)) for k, v in procs.items()}

        # what the system costs while no message comes (timers, polling), once the
        # start-up (imports, discovery) has settled
        time.sleep(args.settle)
        cpu0, t0 = cpu_now(), time.monotonic()
        time.sleep(args.idle)
        cpu1, t1 = cpu_now(), time.monotonic()
        result["cpu_idle_percent_of_one_core"] = {
            k: 100.0 * (cpu1[k] - cpu0[k]) / (t1 - t0) for k in procs
        }
        probe_cmd = [
            *PLACE["probe"],
            sys.executable,
            str(BENCH / "_latency_probe.py"),
            "--input",
            topic(prefix, "in"),
            "--output",
            topic(prefix, "out"),
            "--rate",
            f"{args.rate:g}",
            "--duration",
            f"{args.part:g}",
            "--warmup",
            f"{args.warmup:g}",
        ]
        probe = Child("probe", probe_cmd, child_env())
        started.append(probe)
        probe.wait_for("probe: measuring", 90)
        cpu0, t0 = cpu_now(), time.monotonic()
        result["scheduling"] = {k: sched_of(v[0]) if v else "gone" for k, v in procs.items()}
        result["scheduling"]["probe"] = sched_of(probe.pid)
        if system == "rtcf":  # the bridge's publishing and taking threads (timed: FIFO)
            result["scheduling"]["publishing thread"] = fifo_threads(procs[
                "supervisor (ROS 2 bridge thread)"][0])
        probe.wait_for("probe: measured", args.part + 60)
        cpu1, t1 = cpu_now(), time.monotonic()
        result["cpu_percent_of_one_core"] = {
            k: 100.0 * (cpu1[k] - cpu0[k]) / (t1 - t0) for k in procs
        }
        rc = probe.finish(60)
        if rc != 0:
            raise c.BenchmarkError(f"probe failed on {system} (exit {rc}): {probe.tail()}")
        data = json.loads("".join(probe.stdout))
        if system == "rtcf":
            rc = system_procs[0].stop(30)
            if rc != 0:
                raise c.BenchmarkError(f"rtcf launch failed (exit {rc}): {system_procs[0].tail()}")
            path = report / "timing.json"
            if not path.exists():
                raise c.BenchmarkError(f"rtcf wrote no {path}: {system_procs[0].tail()}")
            timing = json.loads(path.read_text())
            timing.pop("histograms_ns", None)
            result["rtcf_timing"] = timing
        else:
            for p in system_procs:  # all at once, then wait for each
                with contextlib.suppress(ProcessLookupError):
                    p.proc.send_signal(signal.SIGINT)
            for p in system_procs:
                p.stop()
    result.update(data)
    return result


# -- numbers --------------------------------------------------------------------------


def merge(rounds: list[dict[str, Any]], frequency: float) -> dict[str, Any]:
    """One series per system from its rounds (samples pooled, counts summed)."""
    latency = [x for r in rounds for x in r["latency_us"]]
    variation = [x for r in rounds for x in r["delay_variation_us"]]
    gaps = [x for r in rounds for x in r["lost_next_sent_after_us"]]
    measured = sum(r["measured_s"] for r in rounds)
    cpu: dict[str, float] = {}
    idle: dict[str, float] = {}
    for r in rounds:
        for k, v in r["cpu_percent_of_one_core"].items():
            cpu[k] = cpu.get(k, 0.0) + v / len(rounds)
        for k, v in r["cpu_idle_percent_of_one_core"].items():
            idle[k] = idle.get(k, 0.0) + v / len(rounds)
    out: dict[str, Any] = {
        "latency_us": c.summarize(latency),
        "latency_stdev_us": statistics.pstdev(latency) if latency else math.nan,
        "arrival_jitter_us": c.summarize([abs(x) for x in variation]),
        # a periodic system's output messages: |interval - period| (what a subscriber
        # sees of the loop's timing; the others do not publish periodically)
        "period_jitter_us": c.summarize(
            [abs(x - 1e6 / frequency) for r in rounds for x in r.get("output_interval_us", [])]
        ),
        "sent": sum(r["sent"] for r in rounds),
        "received": sum(r["received"] for r in rounds),
        "lost": sum(r["lost"] for r in rounds),
        "lost_next_sent_within_a_period": sum(1 for g in gaps if g < 1e6 / frequency),
        "stale_outputs": sum(r["stale_outputs"] for r in rounds),
        "output_rate_hz": sum(r["outputs"] for r in rounds) / measured if measured else math.nan,
        "cpu_percent_of_one_core": sum(cpu.values()),
        "cpu_percent_by_process": cpu,
        "cpu_idle_percent_of_one_core": sum(idle.values()),
        "cpu_idle_percent_by_process": idle,
        "scheduling": rounds[0]["scheduling"],
        "graph_topics": rounds[0]["graph_topics"],
    }
    timings = [r["rtcf_timing"] for r in rounds if "rtcf_timing" in r]
    if timings:
        out["rtcf_loop"] = {
            "iterations": sum(t["iterations"] for t in timings),
            "overruns": sum(t["overruns"] for t in timings),
            "jitter_us_per_round": [t["jitter_us"] for t in timings],
            "calc_us_per_round": [t["calc_us"] for t in timings],
            "realtime": timings[0].get("realtime", {}),
        }
    return out


def ms(x: float | None) -> str:
    return c.fmt(None if x is None else x / 1e3, 2)


def report(merged: dict[str, dict[str, Any]]) -> tuple[str, str]:
    """The latency table and the table of how each system ran (markdown)."""
    rows = []
    for system in SYSTEMS:
        m = merged[system]
        lat = m["latency_us"]
        rows.append(
            [
                LABEL[system],
                *(ms(lat.get(k)) for k in c.COLUMNS),
                ms(m["latency_stdev_us"]),
                f"{m['lost']} / {m['sent']}",
            ]
        )
    latency = c.table(["end-to-end latency [ms]", *c.LABELS, "std dev", "lost / sent"], rows)
    rows = []
    for system in SYSTEMS:
        m = merged[system]
        jit = m["arrival_jitter_us"]
        split = m["cpu_percent_by_process"]
        rows.append(
            [
                LABEL[system],
                *(ms(jit.get(k)) for k in ("p50", "p99", "p999", "max")),
                ms(m["period_jitter_us"].get("p99")) if system in PERIODIC else "",
                c.fmt(m["output_rate_hz"], 0),
                c.fmt(m["cpu_percent_of_one_core"], 0),
                " + ".join(f"{k.split(' ')[0]} {c.fmt(v, 0)}" for k, v in split.items()),
                c.fmt(m["cpu_idle_percent_of_one_core"], 0),
            ]
        )
    arrival = c.table(
        [
            "output arrival jitter [ms]",
            "p50",
            "p99",
            "p99.9",
            "max",
            "period jitter p99",
            "outputs/s",
            "CPU [% of a core]",
            "by process",
            "CPU, no messages",
        ],
        rows,
    )
    return latency, arrival


# issue 22's goals for what ROS sees of the loop, against the echo (rclpy's floor)
JITTER_RATIO_GOAL = 1.5
LATENCY_MARGIN_MS = 0.2
SUPERVISOR_CPU_GOAL = 25.0


def goals(merged: dict[str, dict[str, Any]], frequency: float) -> dict[str, Any]:
    """rtcf against the echo: the ratios and margins of the goals, and whether each is
    met. A periodic output's jitter is |interval - period| between its messages; the
    echo's, |arrival interval - send interval| (it answers each message, no period):
    both are what one rclpy hop adds to the timing a subscriber sees. The first-arrival
    jitter of rtcf's numbers also holds the wait for the loop's next iteration, uniform
    in one period (its p99 is about 0.9 T by itself), so it is reported, not a goal."""
    rtcf, echo = merged["rtcf"], merged["ros_echo"]
    period_ms = 1e3 / frequency
    bridge = rtcf["period_jitter_us"].get("p99", math.nan)
    floor = echo["arrival_jitter_us"].get("p99", math.nan)
    first = rtcf["arrival_jitter_us"].get("p99", math.nan)
    latency = rtcf["latency_us"].get("p50", math.nan) / 1e3
    bound = echo["latency_us"].get("p50", math.nan) / 1e3 + period_ms / 2 + LATENCY_MARGIN_MS
    supervisor = sum(v for k, v in rtcf["cpu_percent_by_process"].items()
                     if k.startswith("supervisor"))
    out = {
        "period_jitter_p99_ratio_to_echo": bridge / floor if floor else math.nan,
        "first_arrival_jitter_p99_ratio_to_echo": first / floor if floor else math.nan,
        "latency_p50_ms": latency,
        "latency_p50_bound_ms": bound,
        "supervisor_cpu_percent": supervisor,
        "lost": rtcf["lost"],
        "sent": rtcf["sent"],
    }
    out["met"] = {
        "jitter": out["period_jitter_p99_ratio_to_echo"] <= JITTER_RATIO_GOAL,
        "latency": latency <= bound,
        "cpu": supervisor < SUPERVISOR_CPU_GOAL,
        "lost": rtcf["lost"] == 0,
    }
    return out


def goals_line(g: dict[str, Any]) -> str:
    def verdict(key: str) -> str:
        return "met" if g["met"][key] else "NOT met"

    return (
        f"Goals (issue 22): rtcf's output period jitter p99 is "
        f"{c.fmt_ratio(g['period_jitter_p99_ratio_to_echo'])} the echo's arrival jitter p99 "
        f"(≤ {JITTER_RATIO_GOAL}x: {verdict('jitter')}; the first arrival of each number, "
        f"which waits for the next iteration, "
        f"{c.fmt_ratio(g['first_arrival_jitter_p99_ratio_to_echo'])}); "
        f"latency p50 {g['latency_p50_ms']:.2f} ms against the echo's + T/2 + "
        f"{LATENCY_MARGIN_MS} ms = {g['latency_p50_bound_ms']:.2f} ms ({verdict('latency')}); "
        f"supervisor {g['supervisor_cpu_percent']:.0f} % of a core (< {SUPERVISOR_CPU_GOAL:g} %: "
        f"{verdict('cpu')}); lost {g['lost']} of {g['sent']} ({verdict('lost')})."
    )


def periods_line(merged: dict[str, dict[str, Any]], frequency: float) -> str:
    """The medians in loop periods, and rtcf's beside the echo's plus half a period."""
    period_ms = 1e3 / frequency
    p50 = {s: merged[s]["latency_us"].get("p50", math.nan) / 1e3 for s in SYSTEMS}
    floor = p50["ros_echo"] + period_ms / 2
    return (
        f"Medians in loop periods (T = {period_ms:g} ms): rtcf {p50['rtcf'] / period_ms:.2f} T, "
        f"ROS-only with timers {p50['ros_timer'] / period_ms:.2f} T, subscription-driven "
        f"{p50['ros_event'] / period_ms:.2f} T. The echo's median plus half a period (the "
        f"mean wait for rtcf's next iteration) is {floor:.2f} ms; rtcf's median is "
        f"{abs(p50['rtcf'] - floor):.2f} ms {'above' if p50['rtcf'] >= floor else 'below'} "
        "that."
    )


def per_round_line(rounds: dict[str, list[dict[str, Any]]]) -> str:
    """Each system's median in each round: how much the host moved them."""
    parts = [
        f"{s.removeprefix('ros_')} "
        + ", ".join(ms(c.summarize(r["latency_us"]).get("p50")) for r in rounds[s])
        for s in SYSTEMS
    ]
    return "Median per round [ms]: " + "; ".join(parts) + "."


def conditions_line(merged: dict[str, dict[str, Any]], wrapper: Sequence[str]) -> str:
    rt = merged["rtcf"].get("rtcf_loop", {}).get("realtime", {})
    loop = (
        f"rtcf's loop: {rt.get('scheduler')} {rt.get('priority') or ''}".rstrip()
        + f", CPUs {rt.get('cpu_affinity')}, mlockall {rt.get('mlockall')}"
        + (f" (run under `{' '.join(wrapper)}`)" if wrapper else "")
    )
    sched = merged["rtcf"]["scheduling"]
    ros = merged["ros_timer"]["scheduling"]
    return (
        f"{loop}; rtcf's supervisor, which holds the ROS 2 bridge thread: "
        f"{sched.get('supervisor (ROS 2 bridge thread)')}, its threads that publish and "
        f"take messages {sched.get('publishing thread', '?')} (bridge "
        f"{os.environ.get('RTCF_ROS2_BRIDGE', 'timed')}); the ROS-only nodes: "
        f"{ros.get('H1')}; the probe: {ros.get('probe')}"
    )


def main() -> int:
    p = c.parser(__doc__.splitlines()[0], DURATION)
    p.add_argument(
        "--rounds",
        type=int,
        default=None,
        help=f"alternating rounds that share each system's duration (default {ROUNDS}; 1 quick)",
    )
    p.add_argument(
        "--frequency",
        type=float,
        default=FREQUENCY,
        help=f"loop rate of every system [Hz] (default {FREQUENCY:g}); other than the "
        "defaults, results go to results/ros2_latency-<frequency>hz-<rate>hz.json and the "
        "docs are left alone",
    )
    p.add_argument(
        "--rate", type=float, default=RATE, help=f"probe messages per second (default {RATE:g})"
    )
    p.add_argument(
        "--deadline", type=float, default=0.0, metavar="S",
        help="give rtcf's mapped input an input deadline of S seconds (results "
        "ros2_latency-...-deadline, docs left alone)",
    )
    p.add_argument(
        "--hosts",
        type=int,
        choices=(1, 2),
        default=1,
        help="2: the systems on one host and the probe on another, two network namespaces "
        "joined by a veth pair, DDS over UDP (needs root); results and docs section "
        "ros2_latency-2hosts",
    )
    args = p.parse_args()
    c.require_ros2()
    args.duration = args.duration or (2.0 if args.quick else DURATION)
    args.rounds = max(1, args.rounds or (1 if args.quick else ROUNDS))
    args.part = args.duration / args.rounds
    args.warmup = 0.5 if args.quick else 1.0
    args.settle, args.idle = (0.3, 0.5) if args.quick else (0.5, 1.0)  # before the probe
    domain = os.environ.get("ROS_DOMAIN_ID", "")
    machine = c.machine_info()
    started = time.perf_counter()
    rounds: dict[str, list[dict[str, Any]]] = {s: [] for s in SYSTEMS}
    with c.workdir() as work, contextlib.ExitStack() as stack:
        if args.hosts == 2:
            try:
                system_host, probe_host = stack.enter_context(_hosts.two_hosts())
            except PermissionError as exc:
                raise c.BenchmarkError(f"--hosts 2: {exc}") from None
            PLACE["system"] = system_host.command()
            PLACE["probe"] = probe_host.command()
            HOST_ENV.update(_hosts.UDP_ONLY)
            print(f"two hosts: the systems on {system_host.address}, the probe on "
                  f"{probe_host.address} (UDP over a veth pair)", file=sys.stderr)
        wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
        print(
            f"{', '.join(SYSTEMS)} at {args.frequency:g} Hz, probe at {args.rate:g} Hz, "
            f"{args.rounds} alternating rounds of {args.part:g} s each "
            f"(ROS_DOMAIN_ID {domain or 'unset: 0'}) ...",
            file=sys.stderr,
        )
        load_before = c.load_avg()
        with c.cpu_dma_latency_zero() as held:
            for r in range(args.rounds):
                order = SYSTEMS[r % len(SYSTEMS) :] + SYSTEMS[: r % len(SYSTEMS)]
                for system in order:
                    print(f"  round {r + 1}: {system}", file=sys.stderr)
                    rounds[system].append(run_round(system, args, work, f"{r}", wrapper))
        load_after = c.load_avg()
    elapsed = time.perf_counter() - started
    merged = {s: merge(rounds[s], args.frequency) for s in SYSTEMS}
    latency, arrival = report(merged)
    conditions = conditions_line(merged, wrapper)
    goal = goals(merged, args.frequency)
    c.print_report(
        machine,
        elapsed,
        f"Fig. 1 at {args.frequency:g} Hz, probe at {args.rate:g} Hz, {args.duration:g} s per "
        f"system in {args.rounds} rounds",
        latency,
        "",
        arrival,
        conditions,
        goals_line(goal),
    )
    data: dict[str, Any] = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_system": args.duration,
        "rounds": args.rounds,
        "frequency_hz": args.frequency,
        "probe_rate_hz": args.rate,
        "warmup_s": args.warmup,
        "cpu_no_messages_settle_and_window_s": [args.settle, args.idle],
        "ros_domain_id": domain or None,
        "machine": machine,
        "load_avg_before": load_before,
        "load_avg_after": load_after,
        "cpu_dma_latency_zero": held,
        "rt_wrapper": " ".join(wrapper) or None,
        "ros2_bridge": os.environ.get("RTCF_ROS2_BRIDGE", "timed"),
        "input_deadline_s": args.deadline or None,
        "conditions": conditions,
        "goals": goal,
        "systems": merged,
        "rounds_raw": {
            s: [
                {k: v for k, v in r.items() if not k.endswith("_us")}
                | {"latency_us": c.summarize(r["latency_us"])}
                for r in rounds[s]
            ]
            for s in SYSTEMS
        },
        "elapsed_s": elapsed,
    }
    # the docs hold the default rates (each way of running in a section of its own);
    # other rates are written beside, docs left alone
    rates = args.frequency == FREQUENCY and args.rate == RATE
    default = rates and not args.deadline
    name = NAME if rates else f"{NAME}-{args.frequency:g}hz-{args.rate:g}hz"
    if args.hosts == 2:
        name += "-2hosts"
    if data["ros2_bridge"] != "timed":
        name += f"-{data['ros2_bridge']}-bridge"
    if args.deadline:
        name += "-deadline"
    data["hosts"] = args.hosts
    where = (
        "**Across two hosts**: every system in one network namespace, the probe in "
        "another, joined by a veth pair, DDS over UDP (`--hosts 2`). " if args.hosts == 2
        else ""
    )
    paragraphs = [
        f"{where}Fig. 1 at **{args.frequency:g} Hz** in every system; the probe publishes "
        f"`std_msgs/Float64` sequence numbers at {args.rate:g} Hz on average and "
        f"times the first output carrying each; **{args.duration:g} s per system**, "
        f"in {args.rounds} "
        f"alternating rounds, after {args.warmup:g} s of warm-up per round. "
        f"{conditions}. `/dev/cpu_dma_latency` held at 0 throughout.",
        latency,
        periods_line(merged, args.frequency) + " " + per_round_line(rounds),
        "Output arrival jitter: |interval between the arrivals of two consecutive "
        "numbers minus the interval between their sends| (the probe sends at random "
        f"intervals of {1e3 / args.rate:g} ms ± 50 %, so that the sends sample every "
        "phase of the systems' periods). Outputs/s: messages on the output topic "
        "(rtcf and the timers publish it at the loop rate; the subscription-driven "
        "R3 on each of its four input messages per number; the echo once per "
        "number). Period jitter: |interval between two output messages in a row "
        "minus the loop's period|, for the systems that publish once per period. "
        "CPU: user + system time of the system's processes (rtcf: "
        "supervisor and worker) over the measured time, 100 % = one core; "
        f"no messages: the same over {args.idle:g} s before the probe started "
        f"({args.settle:g} s after the system was up).",
        arrival,
        goals_line(goal),
    ]
    c.write_results(name, data, args.quick, paragraphs if default else ())
    return 0


if __name__ == "__main__":
    c.main_guard(main)
