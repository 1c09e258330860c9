"""The ``rtcf`` command line: launch, graph and check launch files."""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import Any

from .. import __version__
from .._core import _hotpath
from .._core._clock import SimClock
from .._core._command_limits import describe_summary
from .._core._errors import LaunchError, RtcfError
from .._core._graph import Graph, to_dot, to_mermaid
from .._core._names import basename, namespace_of
from .._core._runner import Runner, RunResult
from .._launch._deployment import Deployment, RunnerDeployment
from .._launch._files import load_deployment
from .._runtime._admission import access_of
from .._runtime._live import FoxgloveLive, RecordSinks
from .._runtime._mcap import McapRecording
from .._runtime._supervisor import Bridge, LiveStatus, WorkerRunner
from . import _evaluate, _recording_tools
from . import _replay as _replay_command
from ._costs import apply_measured_costs
from ._introspection import mapping
from ._logconfig import apply_rosconsole
from ._other_nodes import OtherNodes, check_lines
from ._report import can_plot, format_summary, timing_document, write_report

EPILOG = """\
examples:
  rtcf launch rtcf_examples paper_evaluation.launch --duration 3
  rtcf launch my_system.launch frequency:=500 --sim --duration 10
  rtcf graph rtcf_examples complex_architecture.launch --format dot | dot -Tpng > g.png
  rtcf check my_system.launch
"""


class _Formatter(logging.Formatter):
    """ROS-like console lines: [LEVEL] [t=... #iteration] [/component]: message."""

    def format(self, record: logging.LogRecord) -> str:
        component = getattr(record, "rtcf_component", None)
        level = "FATAL" if record.levelno >= logging.CRITICAL else record.levelname
        if component is None:
            return f"[{level}] [{record.name}]: {record.getMessage()}"
        iteration = getattr(record, "rtcf_iteration", -1)
        when = f" #{iteration}" if iteration >= 0 else ""
        return f"[{level}]{when} [{component}]: {record.getMessage()}"


def _setup_logging(level: str) -> None:
    handler = _Handler(sys.stderr)
    handler.setFormatter(_Formatter())
    root = logging.getLogger("rtcf")
    root.handlers[:] = [handler]
    root.setLevel(level.upper())
    root.propagate = False


def _say(text: str) -> None:
    print(f"rtcf: {text}", file=sys.stderr, flush=True)


def _load(words: Sequence[str], costs: str | None = None) -> Deployment:
    deployment = load_deployment(words)
    for warning in deployment.warnings:
        _say(f"warning: {warning}")
    for note in deployment.notes:  # the robot description each runner reads
        _say(note)
    if costs is not None:
        for note in apply_measured_costs(deployment, costs):
            _say(note)
    return deployment


def _build_runner(target: RunnerDeployment, deployment: Deployment) -> Runner:
    """The runner of ``target`` in this process, to inspect (on the simulated clock; its
    hardware, if any, offline: nothing on the robot is touched)."""
    runner = Runner(
        target.settings,
        clock=SimClock(),
        parameters=deployment.parameters,
        name=target.name,
        offline=True,
    )
    try:
        for spec in target.components:
            runner.load(spec)
        runner.graph  # noqa: B018 - resolve now so graph errors surface before running
    except BaseException as exc:
        if isinstance(exc, RtcfError) and exc.file is None:
            exc.file = deployment.source  # a graph error belongs to the whole file
        for err in runner.shutdown():
            _say(f"error: {err}")
        raise
    for warning in runner.graph.warnings:
        _say(f"warning: {target.name}: {warning}")
    return runner


def _describe_graph(graph: Graph, runner: Runner) -> str:
    settings = runner.settings
    lines = [f"runner {runner.name}: {settings.frequency:g} Hz, mode {settings.mode}"]
    if access_of(settings):
        lines.append(f"access: {access_of(settings)}")
    lines.append(f"components ({len(graph.nodes)}):")
    for node in sorted(graph.nodes, key=lambda n: graph.order.index(n.name)):
        flags = " [is_first]" if node.is_first else ""
        if node.ignore_pattern is not None:
            flags += f" [topics_ignore_for_graph: {node.ignore_pattern.pattern}]"
        lane = f" [lane {node.lane}]" if len({n.lane for n in graph.nodes}) > 1 else ""
        lines.append(f"  {node.name} ({node.label}){flags}{lane}")
        for p in node.inputs:
            lines.append(f"    in  {p.name:<12} <- {p.topic} [{p.type.__name__}]")
        for p in node.outputs:
            lines.append(f"    out {p.name:<12} -> {p.topic} [{p.type.__name__}]")
    lines.append(f"connections ({len(graph.edges)}):")
    for e in sorted(graph.edges, key=lambda e: (e.topic, e.consumer.qualified_name)):
        late = (
            "at the lane's release or window's end"
            if e.ignored_by == "logical execution time"
            else "one iteration late"
        )
        note = "" if e.orders else f"   (not ordered: {e.ignored_by}; {late})"
        lines.append(
            f"  {e.topic}: {e.producer.qualified_name} -> {e.consumer.qualified_name}{note}"
        )
    mapped_out = [p for n in graph.nodes for p in n.outputs if settings.maps_to_ros(p.topic)]
    mapped_in = [p for p in graph.unconnected_inputs if settings.maps_to_ros(p.topic)]
    if mapped_out or mapped_in:
        lines.append("mapped to middleware topics (ros_mapping_whitelist/blacklist):")
        lines.extend(f"  {p.topic} <- {p.qualified_name}" for p in mapped_out)
        lines.extend(f"  {p.topic} -> {p.qualified_name}" for p in mapped_in)
    unfed = [p for p in graph.unconnected_inputs if not settings.maps_to_ros(p.topic)]
    if unfed:
        lines.append("inputs with no producer (they read None):")
        lines.extend(f"  {p.qualified_name} <- {p.topic}" for p in unfed)
    lines.append("order: " + " -> ".join(graph.order))
    lines.extend(_rate_plan(runner))
    return "\n".join(lines)


def _rate_plan(runner: Runner) -> list[str]:
    """The multi-rate plan: which components run in which iteration of the hyperperiod."""
    return runner.rate_plan() or []


def cmd_graph(ns: argparse.Namespace) -> int:
    deployment = _load(ns.target, ns.costs)
    for target in deployment.runners:
        runner = _build_runner(target, deployment)
        try:
            graph = runner.graph
            if ns.format == "dot":
                sys.stdout.write(to_dot(graph))
            elif ns.format == "mermaid":
                sys.stdout.write(to_mermaid(graph))
            else:
                print(_describe_graph(graph, runner))
        finally:
            runner.shutdown()
    return 0


def cmd_check(ns: argparse.Namespace) -> int:
    deployment = _load(ns.target, ns.costs)
    for line in check_lines(deployment.other_nodes):  # what rtcf launch would start
        _say(line)
    for target in deployment.runners:
        runner = _build_runner(target, deployment)
        try:
            reason = runner.not_ready_reason()
            graph = runner.graph
            if reason and target.settings.mode != "wait_for_trigger":
                raise LaunchError(
                    f"runner {target.name}: the loop would never start: {reason}",
                    file=target.location.file,
                    line=target.location.line,
                )
            for spec in target.components:  # what the runner would refuse to load
                if not target.settings.allows_module(spec.module):
                    raise LaunchError(
                        f"runner {target.name}: component {spec.full_name}'s module "
                        f"{spec.module!r} is not in its allowed_modules "
                        f"({' '.join(target.settings.allowed_modules)})",
                        file=target.location.file, line=target.location.line)
            problems = runner.hardware_problems()
            if problems:  # each refusal the controller manager would answer with
                for problem in problems[:-1]:
                    _say(f"error: {target.location}: {problem}")
                raise LaunchError(problems[-1], file=target.location.file,
                                  line=target.location.line)
            print(
                f"{deployment.source}: OK: runner {target.name}, {len(graph.order)} components, "
                f"{len(graph.edges)} connections, order: " + " -> ".join(graph.order)
            )
            if access_of(target.settings):
                print(f"access: {access_of(target.settings)}")
            for line in _rate_plan(runner):
                print(line)
        finally:
            errors = runner.shutdown()
        if errors:
            raise errors[0]
    return 0


def cmd_launch(ns: argparse.Namespace) -> int:
    deployment = _load(ns.target, ns.costs)
    target = deployment.runner
    settings = target.settings
    for note in apply_rosconsole(target, ns.middleware, ns.log_level):  # start levels
        _say(note)
    if ns.report and not ns.sim and not can_plot():  # say so now, not after the run
        _say(
            f"note: --report {ns.report}: matplotlib is not installed, so timing.png will "
            "be skipped (pip install 'rtcf[plot]'); timing.json will be written"
        )
    recording = _recording(ns) if ns.record else None
    if recording is not None:  # the timing rows too: rtcf evaluate run.mcap reads them
        recording.timing_topic = f"{target.name.rstrip('/')}/iteration_info"
    live = _live(ns) if ns.foxglove is not None else None
    sink = RecordSinks(recording, live) if recording and live else (recording or live)
    status_line = None if ns.quiet else _STATUS
    bridge = _bridge(ns.middleware, target.name)
    runner = WorkerRunner(
        settings,
        name=target.name,
        parameters=deployment.parameters,
        simulated=ns.sim,
        log_level=ns.log_level,
        on_status=status_line.show if status_line else None,
        on_started=lambda realtime: _say_realtime(realtime, ns.sim),
        bridge=bridge,
    )
    runner.lanes.say = False  # its lanes line below says where each lane runs
    runner.controller_setup = target.controllers  # list_controller_types, load refusals
    status = 0
    nodes = OtherNodes(deployment.other_nodes, deployment.parameters, say=_say_above,
                       write=_write_above, on_shutdown=lambda: runner.request_stop(abort=True))
    previous = _install_stop_handlers(runner, nodes.note_signal)
    try:
        runner.start()
        try:
            for spec in target.components:
                runner.load(spec, refresh=False)
            runner.refresh_introspection()  # once, over all of them
            info = runner.describe()
        except RtcfError as exc:
            if exc.file is None:
                exc.file = deployment.source  # a graph error belongs to the whole file
            raise
        for warning in info["warnings"]:
            _say(f"warning: {target.name}: {warning}")
        reason = info["not_ready"]
        if settings.mode == "wait_for_trigger" and reason:
            _say("mode wait_for_trigger: no middleware to trigger it, so the loop starts now")
            runner.activate()
            reason = runner.describe()["not_ready"]
        if reason:
            raise LaunchError(
                f"runner {target.name}: the loop would never start: {reason}",
                file=target.location.file,
                line=target.location.line,
            )
        iterations = (
            None if ns.duration is None else max(1, round(ns.duration * settings.frequency))
        )
        _say(
            f"runner {target.name}: {len(info['components'])} components at "
            f"{settings.frequency:g} Hz (mode {settings.mode}, "
            f"wait_policy {settings.wait_policy}), loop in worker process {runner.pid}"
        )
        _say("order: " + " -> ".join(info["order"]))
        if len(info.get("lanes", [])) > 1:
            where = runner.lanes.placement
            _say(
                "lanes: "
                + "; ".join(
                    f"{name} ({'LET, every ' + str(every) if every > 1 else 'lock step'}"
                    + (f"; {where[name]}" if name in where else "")
                    + "): "
                    + (", ".join(members) or "no component")
                    for name, every, members in info["lanes"]
                )
                + "; each lane a worker process of its own (docs/runner.md#lanes)"
            )
        if bridge is not None:
            mapped = mapping(runner.introspect(), settings.ros_mapping_whitelist)
            _say(f"{ns.middleware}: {mapped}")
        if iterations is None:
            _say("running until Ctrl-C")
        else:
            kind = "simulated" if ns.sim else "/clock" if settings.use_sim_time else "real"
            _say(f"running {iterations} iterations ({kind} time)")
        nodes.start()  # the file's other nodes, as ros2 launch would (_other_nodes)
        started = time.perf_counter()
        try:
            result = runner.run(iterations, trace=ns.trace, record=sink)
        except RtcfError as exc:  # a component, a watchdog, a hook that hung, a dead worker
            if ns.debug:
                print(getattr(exc, "worker_traceback", ""), file=sys.stderr, end="")
            _say(f"error: {exc}")
            status = 1
            result = None
        finally:
            wall = time.perf_counter() - started
            if status_line:
                status_line.clear()
            nodes.stop()
        if nodes.shutdown_by is not None:
            status = 1
        if ns.trace and result is not None:
            _say(f"wrote {ns.trace}")
        if recording is not None:  # also after a fault: what led to it is in the file
            _finish_recording(recording, deployment, target, ns, result, wall)
        if live is not None:
            _say(f"foxglove: sent {live.sent} messages")
            live.close()
        if result is not None:
            for fault in result.faults:
                _say(f"fault: {fault.describe()}")
            for port, d in result.deadlines.items():
                if d["expired"]:
                    _say(
                        f"deadline: input {port!r} ({d['topic']}) passed its deadline of "
                        f"{d['deadline']:g} s {d['expired']} time{'s' * (d['expired'] != 1)}, "
                        f"{d['expired_seconds']:.3f} s "
                        "in all" + (" (still past it at the end)" if d["past_deadline_now"] else "")
                    )
            for port, d in result.command_limits.items():
                line = describe_summary(port, d)
                if line:
                    _say(line)
            if result.stopped_by == "abort":
                done = ", ".join(o.describe() for o in result.safe_stops) or "none defined"
                _say(f"stopped abnormally; safe stops: {done}")
        if result is not None:
            print(format_summary(result, settings, wall), flush=True)
            if ns.report:
                for path in write_report(ns.report, result, settings, wall):
                    _say(f"wrote {path}")
            if result.log_records_dropped:
                _say(
                    f"warning: {result.log_records_dropped} log records were dropped "
                    "(the log ring was full); log less often from update()"
                )
        for err in runner.shutdown():
            _say(f"error: {err}")
            status = 1
    finally:
        nodes.stop()
        _restore_handlers(previous)
        runner.close()
    return status


def _recording(ns: argparse.Namespace) -> McapRecording:
    # ROS 2 message definitions from the .msg files of the installed packages (no rclpy)
    from .._ros2._msgdef import message_definition

    return McapRecording(ns.record, ns.record_topics, message_definition=message_definition)


def _live(ns: argparse.Namespace) -> FoxgloveLive:
    from .._ros2._msgdef import message_definition

    if ns.foxglove_host not in ("127.0.0.1", "localhost", "::1") and not ns.foxglove_any_host:
        raise LaunchError(
            f"--foxglove-host {ns.foxglove_host}: serving the loop's signals beyond loopback "
            "needs --foxglove-any-host too (anyone who reaches the port sees every value)"
        )
    live = FoxgloveLive(
        ns.foxglove_host, ns.foxglove, ns.foxglove_rate, ns.record_topics,
        message_definition=message_definition,
    )
    _say(f"foxglove: serving {live.url} ({ns.foxglove_rate:g} messages per second per "
         "topic at most); open it in Foxglove with 'Open connection'")
    return live


def _finish_recording(
    recording: McapRecording,
    deployment: Deployment,
    target: RunnerDeployment,
    ns: argparse.Namespace,
    result: RunResult | None,
    wall: float,
) -> None:
    """The metadata and attachments that make the file reproduce the run, then close."""
    settings = target.settings
    source = Path(deployment.source) if deployment.source else None
    attachments: dict[str, tuple[str, bytes]] = {
        "settings.json": (
            "application/json",
            json.dumps(dataclasses.asdict(settings), indent=2, default=str).encode(),
        ),
    }
    if source is not None and source.is_file():
        attachments[f"launch/{source.name}"] = ("application/xml", source.read_bytes())
    metadata: dict[str, Any] = {
        "rtcf_version": __version__,
        "launch_file": str(source) if source else "",
        "launch_arguments": [w for w in ns.target if ":=" in w],
        "runner": target.name,
        "frequency_hz": settings.frequency,
        "middleware": ns.middleware,
        "simulated": ns.sim,
        "record_topics": ns.record_topics,
    }
    if result is not None:
        metadata["iterations"] = result.iterations
        metadata["order"] = result.order
        metadata["stopped_by"] = result.stopped_by
        doc = timing_document(result, settings, wall)
        attachments["timing.json"] = ("application/json", json.dumps(doc, indent=2).encode())
    recording.finish(metadata, attachments)
    _say(recording.summary())


def _bridge(middleware: str, runner_name: str) -> Bridge | None:
    if middleware == "none":
        return None
    if middleware == "ros1":
        from .._ros1._bridge import Ros1Bridge

        ros1 = Ros1Bridge(basename(runner_name), namespace_of(runner_name))
        _say(f"middleware ros1: node {runner_name}")
        return ros1
    from .._ros2._bridge import Ros2Bridge

    bridge = Ros2Bridge(basename(runner_name), namespace_of(runner_name))
    _say(f"middleware ros2: node {runner_name}")
    return bridge


def _say_realtime(realtime: dict[str, Any], simulated: bool) -> None:
    """One line for what took effect, one per setting that did not (with its reason)."""
    hot = realtime.get("hot_path") or {}
    path = "hot path compiled (C)" if hot.get("path") == "compiled" else "hot path in Python"
    if hot.get("component_clock") == "TSC":
        path += ", components timed by the TSC"
    if hot.get("path") == "Python" and hot.get("why") != _hotpath.FORCED:
        _say(f"warning: the loop's hot path runs in Python, several times slower per "
             f"component: {hot.get('why')}")
    if simulated:
        _say(f"simulated clock: no real-time settings applied; {path}")
        return
    items = realtime.get("applied", [])
    short = {
        "scheduler": lambda i: i["requested"],
        "cpu_affinity": lambda i: i["requested"],
        "mlockall": lambda i: "mlockall",
        "heap_prefault": lambda i: f"heap {i['requested']} pre-faulted",
        "stack_prefault": lambda i: f"stack {i['requested']} pre-faulted",
        "gc": lambda i: "gc frozen",
        "timer_slack": lambda i: f"timer slack {i['requested']}",
        "cpu_dma_latency": lambda i: "cpu_dma_latency 0",
    }
    done = [short.get(i["name"], lambda i: i["name"])(i) for i in items if i["ok"]]
    _say(
        "real-time: "
        + (", ".join(done) if done else "nothing applied")
        + f"; kernel {realtime.get('kernel_preemption')}; {path}"
    )
    for item in items:
        if not item["ok"]:
            _say(f"warning: real-time: {item['name']} NOT applied: {item['detail']}")


class _StatusLine:
    """One line on a terminal that shows progress; log lines print above it."""

    def __init__(self) -> None:
        self.shown = False

    def show(self, st: LiveStatus) -> None:
        if not sys.stderr.isatty():
            return
        text = (
            f"{st.elapsed_s:7.1f} s  {st.iterations:>9} iterations  {st.overruns} overruns  "
            f"jitter p99.9 {st.jitter_p999_us:.1f} µs  calc p99.9 {st.calc_p999_us:.1f} µs  "
            f"max {st.calc_max_us:.1f} µs"
        )
        if st.log_records_dropped:
            text += f"  {st.log_records_dropped} log records dropped"
        if st.past_deadline:
            text += f"  past deadline: {', '.join(st.past_deadline)}"
        if st.commands_clamped or st.commands_refused:
            text += f"  commands clamped {st.commands_clamped}, refused {st.commands_refused}"
        sys.stderr.write("\r" + text + "\x1b[K")
        sys.stderr.flush()
        self.shown = True

    def clear(self) -> None:
        if self.shown:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()
            self.shown = False


_STATUS = _StatusLine()


class _Handler(logging.StreamHandler):  # type: ignore[type-arg,unused-ignore]
    """Clears the status line before a log line, so the two never mix."""

    def emit(self, record: logging.LogRecord) -> None:
        _STATUS.clear()
        super().emit(record)


def _say_above(text: str) -> None:  # from the nodes' threads too
    _STATUS.clear()
    _say(text)


def _write_above(text: str, is_stderr: bool) -> None:
    _STATUS.clear()
    print(text, file=sys.stderr if is_stderr else sys.stdout, flush=True)


def _install_stop_handlers(runner: WorkerRunner,
                           noted: Callable[[int], None] = lambda signum: None) -> dict[int, Any]:
    # counted here: on Ctrl-C the worker gets the signal too and may set the stop word first
    received: list[int] = []

    def handler(signum: int, frame: FrameType | None) -> None:
        name = signal.Signals(signum).name
        noted(signum)
        if received:  # a second one: give up waiting, end the worker at once
            _STATUS.clear()
            if runner.pid is not None and runner.process and runner.process.poll() is None:
                _say(
                    f"second {name}: killed the worker (pid {runner.pid}) at once; hooks "
                    "still to run (stop, cleanup) did not"
                )
                runner.kill()
            raise KeyboardInterrupt
        received.append(signum)
        _STATUS.clear()
        _say(
            f"{name}: stopping after this iteration; the components' safe_stop hooks run "
            "(again to kill the worker at once)"
        )
        runner.request_stop(abort=True)

    previous: dict[int, Any] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, handler)
    return previous


def _restore_handlers(previous: dict[int, Any]) -> None:
    for sig, old in previous.items():
        signal.signal(sig, old)


def cmd_introspect(ns: argparse.Namespace) -> int:
    from ._introspection import render

    if ns.middleware == "ros1":
        from .._ros1._nodes import fetch_introspection_ros1

        data = fetch_introspection_ros1(ns.runner, ns.timeout)
    else:
        from .._ros2._bridge import fetch_introspection

        data = fetch_introspection(ns.runner, ns.timeout)
    if ns.json:
        print(json.dumps(data, indent=2))
        return 0
    print(render(ns.command, data, getattr(ns, "name", None)))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rtcf",
        description="Run real-time components composed by ROS-style launch files.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"rtcf {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    target_help = "FILE or PACKAGE FILE, then name:=value launch arguments"

    launch = sub.add_parser(
        "launch",
        help="run a launch file",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    launch.add_argument("target", nargs="+", metavar="TARGET", help=target_help)
    launch.add_argument(
        "--duration",
        type=_positive_float,
        metavar="SECONDS",
        help="run frequency x SECONDS iterations, then stop (default: until Ctrl-C)",
    )
    launch.add_argument(
        "--sim",
        action="store_true",
        help="run on a simulated clock as fast as possible (deterministic)",
    )
    launch.add_argument(
        "--report", metavar="DIR", help="write timing.json and timing.png (histograms) into DIR"
    )
    launch.add_argument("--quiet", action="store_true", help="no live status line on a terminal")
    launch.add_argument(
        "--middleware",
        choices=["none", "ros2", "ros1"],
        default="none",
        help="map whitelisted ports to topics of this middleware (default none)",
    )
    launch.add_argument(
        "--trace",
        metavar="CSV",
        help="write every output topic's value after every iteration to CSV",
    )
    launch.add_argument(
        "--log-level",
        default="info",
        choices=["debug", "info", "warning", "error"],
        help="lowest level of component log records shown (default info)",
    )
    launch.add_argument(
        "--record",
        metavar="MCAP",
        help="record every value of every port topic, each iteration, into an MCAP file "
        "(ROS 2 schemas: Foxglove and rosbag2 read it)",
    )
    launch.add_argument(
        "--record-topics",
        metavar="REGEX",
        default=".*",
        help="record only the topics that this full-match regex matches (default: all)",
    )
    launch.add_argument(
        "--foxglove",
        nargs="?",
        const=8765,
        type=int,
        metavar="PORT",
        help="serve the recorded topics live on Foxglove's WebSocket protocol (default "
        "port 8765; 0: any free port), on loopback",
    )
    launch.add_argument(
        "--foxglove-host", default="127.0.0.1", metavar="HOST",
        help="address to serve on (default 127.0.0.1; others need --foxglove-any-host)",
    )
    launch.add_argument(
        "--foxglove-any-host", action="store_true",
        help="allow --foxglove-host to be an address beyond loopback",
    )
    launch.add_argument(
        "--foxglove-rate", type=float, default=50.0, metavar="HZ",
        help="at most this many messages per second of loop time per topic (default 50)",
    )
    _add_costs(launch)
    launch.set_defaults(func=cmd_launch)
    _add_debug(launch)

    graph = sub.add_parser("graph", help="print components, connections and execution order")
    graph.add_argument("target", nargs="+", metavar="TARGET", help=target_help)
    graph.add_argument("--format", choices=["text", "dot", "mermaid"], default="text")
    _add_costs(graph)
    graph.set_defaults(func=cmd_graph, log_level="warning")

    for command, what, arg in (
        ("component_list", "list the components of a running runner", None),
        ("component_info", "a component's ports, parameters and log level", "COMPONENT"),
        ("connection_list", "list the topics that connect components", None),
        ("connection_info", "a topic's type, publishers, subscribers", "TOPIC"),
        ("component_order", "the order the loop runs the components in", None),
    ):
        p = sub.add_parser(command, help=f"{what} (asks a running runner)")
        if arg:
            p.add_argument("name", metavar=arg)
        p.add_argument("--runner", default="/rt_runner", help="the runner's node name "
                       "(default /rt_runner)")
        p.add_argument("--middleware", choices=["ros2", "ros1"], default="ros2",
                       help="how to reach the runner (default ros2)")
        p.add_argument("--timeout", type=_positive_float, default=10.0, metavar="SECONDS")
        p.add_argument("--json", action="store_true", help="print the raw data as JSON")
        p.set_defaults(func=cmd_introspect, log_level="warning")
        _add_debug(p)

    _evaluate.add_parser(sub, _add_debug)
    _recording_tools.add_parsers(sub, _add_debug)
    _replay_command.add_parser(sub, _add_debug)

    check = sub.add_parser("check", help="validate a launch file without running it")
    check.add_argument("target", nargs="+", metavar="TARGET", help=target_help)
    _add_costs(check)
    check.set_defaults(func=cmd_check, log_level="warning")
    _add_debug(graph)
    _add_debug(check)
    return parser


def _add_costs(subparser: argparse.ArgumentParser) -> None:
    subparser.add_argument(
        "--costs",
        metavar="TIMING_JSON",
        help="spread slow components by their measured cost: the p99 calculation times "
        "in a timing.json of --report (where the launch file declares no cost_us)",
    )


def _add_debug(subparser: argparse.ArgumentParser) -> None:
    # also after the command (rtcf check FILE --debug); SUPPRESS keeps 'rtcf --debug check'
    subparser.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks of errors"
    )


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text} is not a positive number of seconds")
    return value


def main(argv: Sequence[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:
        # the reader went away (rtcf graph FILE | head): exit quietly, as cat and grep
        # do; stdout goes to /dev/null so the interpreter's final flush cannot raise
        # again, and the status is the shell's for a process ended by SIGPIPE
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 128 + signal.SIGPIPE


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    """The command line, with ``name:=value`` launch arguments taken anywhere after the
    target (``rtcf launch PKG FILE --middleware ros1 use_ros:=true``, as roslaunch
    takes them), not only before the first option, which is all argparse allows."""
    parser = build_parser()
    ns, extra = parser.parse_known_args(argv)
    stray = [w for w in extra if w.startswith("-") or ":=" not in w]
    if extra and (stray or not isinstance(getattr(ns, "target", None), list)):
        parser.parse_args(argv)  # argparse's own message for what it does not know
    if extra:
        ns.target = [*ns.target, *extra]
    return ns


def _main(argv: Sequence[str] | None) -> int:
    ns = parse_arguments(argv)
    _setup_logging(ns.log_level)
    if ns.debug:
        os.environ.setdefault("RTCF_DEBUG", "1")
    try:
        return int(ns.func(ns))
    except RtcfError as exc:
        if ns.debug:
            remote = getattr(exc, "worker_traceback", "")
            if remote:
                print(f"in the worker process:\n{remote}", file=sys.stderr)
            raise
        _say(f"error: {exc}")
        return 1
    except KeyboardInterrupt:
        _say("interrupted")
        return 130


if __name__ == "__main__":
    sys.exit(main())
