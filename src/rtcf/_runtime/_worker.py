"""The worker process: holds the components and runs the loop, nothing else.

Started by the supervisor as ``python -m rtcf._runtime._worker FD SUPERVISOR_PID``. It
imports, constructs and configures the components, applies the real-time settings
and runs the loop. It imports no middleware, starts no thread and does no
blocking I/O while the loop runs. Everything it tells the supervisor while running
goes through shared memory (log records, timing rows, and the outcomes of lifecycle
transitions, which arrive as update records and are applied at the start of an
iteration); the control connection (a Unix socket, pickled messages) is used only
between runs: load, unload, run, stop.

Messages from the supervisor are ``(command, args)``; the worker answers each with
``("reply", value)`` or ``("error", details)``, and may send ``("event", name,
value)`` before the answer (``started`` when the loop begins).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from types import FrameType
from typing import Any

from .._core._clock import Clock, MiddlewareClock, MonotonicClock, SimClock
from .._core._errors import ComponentError, ConfigurationError, GraphError, LaunchError, RtcfError
from .._core._executor import ABORT, StopFlag
from .._core._hotpath import HeartbeatWatch
from .._core._lane_names import MAIN_LANE
from .._core._lanes import LET_OUT, SEND
from .._core._log import LogWriter
from .._core._params import ParameterStore
from .._core._rings import Mailbox, Ring
from .._core._runner import ComponentSpec, Runner
from .._core._settings import RunnerSettings
from .._core._trace import Trace
from .._core._tunables import UPDATE_RECORD_SIZE, UPDATE_RING_RECORDS, UpdateReader
from ._doorbell import Doorbell
from ._lanes import Aborted, LaneLayout, LaneLink, value_size
from ._port_channels import MappedPort, WorkerPorts, mapped_ports
from ._realtime import FrozenGC, apply_realtime
from ._realtime_report import RealtimeReport
from ._recording import RecordedTopic, WorkerRecording, recorded_topics
from ._shm import Segment, receive_segments
from ._worker_updates import UpdateApplier

WORKER_MODULE = "rtcf._runtime._worker"  # what the supervisor runs with `python -m`

# words of the control segment (int64 each)
CTL_STOP = 0  # non-zero: the loop ends after the current iteration (the supervisor writes it)
CTL_ITERATION = 1  # the last iteration the worker finished a run at (informative)
CTL_RUNNING = 2  # timing column of the component whose update runs now, -1: none (worker)
CTL_HEARTBEAT = 3  # the supervisor counts up while it waits for a run (its sign of life)
CTL_FAULTS = 4  # failures a policy contained so far (the worker counts)
# inputs with a deadline (the worker's watch writes): bit k set while prepare's
# deadlines[k] is past its deadline; and how many times any passed it
CTL_DEADLINES = 5
CTL_DEADLINE_MISSES = 6
# commands the hardware's limits clamped, and those they refused (the worker's guards)
CTL_COMMANDS_CLAMPED = 7
CTL_COMMANDS_REFUSED = 8
CTL_WORDS = 10
CLOCK_MAILBOX_OFFSET = 8 * CTL_WORDS  # the /clock mailbox follows the control words

_ERRORS: dict[str, type[RtcfError]] = {
    cls.__name__: cls
    for cls in (RtcfError, ComponentError, ConfigurationError, GraphError, LaunchError)
}


def error_to_dict(exc: BaseException) -> dict[str, Any]:
    """What the supervisor needs to rebuild the error (exceptions may not pickle)."""
    out: dict[str, Any] = {
        "type": type(exc).__name__,
        "message": str(exc),
        "traceback": "".join(traceback.format_exception(exc)),
    }
    if isinstance(exc, RtcfError):
        out.update(message=exc.message, file=exc.file, line=exc.line)
        out["component"] = getattr(exc, "component", None)
    return out


def error_from_dict(d: dict[str, Any]) -> RtcfError:
    cls = _ERRORS.get(d["type"])
    if cls is None:  # not one of ours: a bug in the worker itself
        return RtcfError(f"the worker failed: {d['type']}: {d['message']}")
    if cls is ComponentError:
        err: RtcfError = ComponentError(
            d["message"], component=d.get("component"), file=d.get("file"), line=d.get("line")
        )
    else:
        err = cls(d["message"], file=d.get("file"), line=d.get("line"))
    err.worker_traceback = d.get("traceback", "")  # type: ignore[attr-defined]
    return err


class Worker:
    def __init__(self, conn: Connection) -> None:
        self.conn = conn
        self.runner: Runner | None = None
        self.segments: list[Segment] = []
        self.log_writer: LogWriter | None = None
        self.updates: UpdateReader | None = None  # tunable values and log levels
        self._update_ring: Ring | None = None
        self._outcome_ring: Ring | None = None  # lifecycle outcomes, back to the supervisor
        self.clock_box: Mailbox | None = None
        self.stop: StopFlag | None = None
        self.settings = RunnerSettings()
        self.simulated = False
        self.realtime: RealtimeReport | None = None
        self.done = False
        self.doorbell: Doorbell | None = None  # the worker rings: outputs to publish
        self.clock_doorbell: Doorbell | None = None  # the supervisor rings: /clock
        self._in_loop = False  # hooks in the loop are not announced over the socket
        self._parameters_set: list[tuple[str, Any]] = []  # params.set() while it ran
        self.link: LaneLink | None = None  # lanes in processes of their own
        self._lane_seg: Segment | None = None

    # -- the command loop ------------------------------------------------------
    def serve(self) -> int:
        handlers: dict[str, Callable[..., Any]] = {
            "hello": self.hello,
            "load": self.load,
            "unload": self.unload,
            "activate": self.activate,
            "deactivate": self.deactivate,
            "describe": self.describe,
            "describe_component": self.describe_component,
            "introspect": self.introspect,
            "set_parameters": self.set_parameters,
            "sync": self.sync,
            "prepare": self.prepare,
            "lane_facts": self.lane_facts,
            "set_lanes": self.set_lanes,
            "bind_lanes": self.bind_lanes,
            "run": self.run,
            "shutdown": self.shutdown,
        }
        while not self.done:
            try:
                command, args = self.conn.recv()
            except (EOFError, OSError):  # the supervisor is gone: clean up and leave
                self.shutdown()
                return 3
            handler = handlers.get(command)
            try:
                args = receive_segments(self.conn, args)  # the memory a command hands over
                if self.updates is not None:  # what was set while no loop ran
                    self.updates()
                if handler is None:
                    raise RtcfError(f"the worker does not know the command {command!r}")
                value = handler(*args)
            except BaseException as exc:  # every failure goes back; the worker lives on
                self._send("error", error_to_dict(exc))
                if not isinstance(exc, Exception):
                    raise
            else:
                self._send("reply", value)
        return 0

    def _send(self, kind: str, *payload: Any) -> None:
        try:
            self.conn.send((kind, *payload))
        except (BrokenPipeError, ConnectionResetError):
            pass

    def _runner(self) -> Runner:
        if self.runner is None:
            raise RtcfError("the worker has not been set up (no hello)")
        return self.runner

    # -- commands ----------------------------------------------------------------
    def hello(
        self,
        sys_path: list[str],
        control_seg: Segment,
        log_seg: Segment,
        updates_seg: Segment,
        settings: RunnerSettings,
        parameters: dict[str, Any],
        name: str,
        simulated: bool,
        log_level: str,
        doorbell_fd: int = -1,
        clock_doorbell_fd: int = -1,
    ) -> dict[str, Any]:
        # import components from exactly where the supervisor would
        sys.path[:] = [p for p in sys_path]
        if doorbell_fd >= 0:  # inherited: rung after each record for the middleware
            self.doorbell = Doorbell(doorbell_fd)
        self.segments += [control_seg, log_seg, updates_seg]
        words = control_seg.buf[:CLOCK_MAILBOX_OFFSET].cast("q")
        self._cells = [
            words[w : w + 1]
            for w in (
                CTL_STOP, CTL_RUNNING, CTL_HEARTBEAT, CTL_FAULTS, CTL_DEADLINES,
                CTL_DEADLINE_MISSES, CTL_COMMANDS_CLAMPED, CTL_COMMANDS_REFUSED,
            )
        ]
        words.release()
        self.stop = StopFlag(self._cells[0])
        self.log_writer = writer = LogWriter(Ring.open(log_seg.buf))
        self._update_ring = Ring.open(updates_seg.buf)
        view = updates_seg.buf[Ring.nbytes(UPDATE_RING_RECORDS, UPDATE_RECORD_SIZE) :]
        self._outcome_ring = Ring.open(view)
        view.release()
        self.settings = settings
        self.simulated = simulated
        store = ParameterStore()
        for key, value in parameters.items():
            store.set(key, value)

        def emit(level: int, logger: str, text: str, iteration: int, time_ns: int) -> None:
            writer.push_waiting(level, logger, text, iteration, time_ns, timeout_s=5.0)

        clock: Clock
        if simulated:
            clock = SimClock()
        elif settings.use_sim_time:
            view = control_seg.buf[CLOCK_MAILBOX_OFFSET:]
            self.clock_box = Mailbox.open(view)
            view.release()
            if clock_doorbell_fd >= 0:  # rung with every /clock message
                self.clock_doorbell = Doorbell(clock_doorbell_fd)
            clock = MiddlewareClock(self.clock_box, self.stop.cell, doorbell=self.clock_doorbell)
        else:
            clock = MonotonicClock()
        self.runner = Runner(
            settings,
            clock=clock,
            parameters=store,
            name=name,
            log_level=log_level,
            log_ring=writer,
            log_emit=emit,
            stop_flag=self.stop,
        )
        running, _, faults, past, misses, clamped, refused = self._cells[1:]
        counters = self.runner.command_counters
        counters.clamped, counters.refused = clamped, refused
        running[0] = -1
        self.runner.running_cell = running
        self.runner.deadlines.bits, self.runner.deadlines.misses = past, misses

        def parameter_set(name: str, value: Any) -> None:  # a component's params.set()
            if self._in_loop:  # a hook between two iterations: told after the run
                self._parameters_set.append((name, value))
            else:
                self._send("event", "parameter_set", (name, value))

        store.observer = parameter_set

        def count_fault(fault: Any) -> None:
            faults[0] += 1

        self.runner.on_fault = count_fault

        def observe(component: str, hook: str) -> None:  # between runs only: a socket send
            if not self._in_loop:
                self._send("event", "hook", (component, hook))

        self.runner.hook_observer = observe
        # applied and answered (a STRICT switch all or nothing): rtcf._runtime._worker_updates
        self.updates = UpdateReader(
            self._update_ring, UpdateApplier(self.runner, self._outcome_ring).apply)
        hardware = self.runner.hardware
        return {"pid": os.getpid(), "python": sys.version.split()[0],
                "hardware": hardware.summary() if hardware is not None else []}

    def sync(self) -> None:
        """Nothing but what every command does first: apply the waiting updates."""

    def load(self, spec: ComponentSpec) -> dict[str, Any]:
        runner = self._runner()
        runner.load(spec)
        return runner.describe_component(spec.full_name)

    def describe_component(self, name: str) -> dict[str, Any]:
        return self._runner().describe_component(name)

    def introspect(self) -> dict[str, Any]:
        return self._runner().introspect()

    def set_parameters(self, values: dict[str, Any]) -> None:
        """Set absolute parameters (a middleware's parameter server), for later loads."""
        store = self._runner().parameters
        for name, value in values.items():
            store.set(name, value)

    def unload(self, name: str) -> None:
        self._runner().unload(name)

    def activate(self) -> None:
        self._runner().activate()

    def deactivate(self) -> None:
        self._runner().deactivate()

    def describe(self) -> dict[str, Any]:
        runner = self._runner()
        graph = runner.graph
        return {
            "components": list(runner.components),
            "order": list(graph.order),
            "warnings": list(graph.warnings),
            "not_ready": runner.not_ready_reason(),
            "edges": len(graph.edges),
            "lanes": [(n, lane.every, list(lane.members)) for n, lane in runner.lanes().items()],
        }

    # -- lanes ---------------------------------------------------------------------
    def lane_facts(self) -> dict[str, Any]:
        """What the other lanes must know of this lane's components."""
        runner = self._runner()
        return {"nodes": runner.graph_nodes(), "members": runner.members()}

    def set_lanes(
        self, lane: str, nodes: list[Any], members: list[Any], mirror: list[str]
    ) -> dict[str, Any]:
        """Run lane ``lane`` of every lane's components (the others' nodes and members
        are given); answer the lanes and the topics this lane hands over, with the
        bytes one value may take."""
        runner = self._runner()
        runner.lane = lane
        runner.set_foreign(nodes, members, mirror)
        lanes = runner.lanes()
        outputs = {p.topic: p for p in _all_outputs(runner)}
        sends: dict[str, tuple[str, int]] = {}
        for step in runner.lane_plan():
            if step.kind in (SEND, LET_OUT):
                sends[step.name] = (lane, value_size(outputs[step.name], lane))
        return {"lanes": lanes, "sends": sends}

    def bind_lanes(self, seg: Segment, layout: LaneLayout) -> None:
        """The run's lanes segment: the handovers of the next compile use it."""
        runner = self._runner()
        self._release_lanes()
        self._lane_seg = seg
        # on /clock time (use_sim_time) as on --sim: no real-time bound on a wait, and
        # every lane waits for the others after each iteration (the same values); but
        # at a real-time priority, so a wait sleeps rather than spins
        on_clock = self.settings.use_sim_time and not self.simulated
        link = LaneLink(seg.buf, layout, runner.lane or MAIN_LANE,
                        simulated=self.simulated or on_clock,
                        period_ns=runner.state.period_ns, nap=on_clock)
        link.bound(runner.state, self._stop(), runner.clock.now_ns)
        self.link = link
        runner.handovers = link.bind
        runner.recompile()

    def _release_lanes(self) -> None:
        if self.link is not None:
            self.link.release()
            self.link = None
        if self._lane_seg is not None:
            self._lane_seg.close()
            self._lane_seg = None

    def prepare(self, bridged: bool, record: str | None = None) -> dict[str, Any]:
        """Compile the schedule and list the mapped ports and the recorded topics (a
        full-match regex, or None); the supervisor sizes their channels."""
        runner = self._runner()
        deadlines = runner.deadlines.names()  # (the launch file's deadlines applied)
        ports = []
        if bridged:
            ports = mapped_ports(*runner.mapped_ports(), runner.mapped_actions(),
                                 self.settings.action_max_goal_bytes)
        recorded = []
        if record is not None:
            fed = runner.mapped_ports()[1] if bridged else []
            recorded = recorded_topics(_all_outputs(runner), fed, record)
        return {
            "schedule": runner.schedule, "ports": ports, "recorded": recorded,
            "deadlines": deadlines,  # bit k of CTL_DEADLINES
        }

    def run(
        self,
        iterations: int | None,
        seg: Segment,
        trace_path: str | None,
        port_seg: Segment | None = None,
        ports: list[MappedPort] | None = None,
        rec_seg: Segment | None = None,
        recorded: list[RecordedTopic] | None = None,
        ros_offset_ns: int | None = None,
        lane_run: int | None = None,
    ) -> dict[str, Any]:
        runner = self._runner()
        link = self.link if lane_run is not None else None
        ring = Ring.open(seg.buf)
        trace = None
        if trace_path:  # a LET lane's outputs as the others see them; the other lanes'
            foreign = runner.foreign_slots() if link is not None else None
            trace = Trace(runner.components, runner.state, runner.visible_slots(), foreign)
        bridge = None
        if port_seg is not None and ports:
            bridge = WorkerPorts(
                port_seg.buf, ports, *runner.mapped_ports(), actions=runner.mapped_actions(),
                doorbell=self.doorbell,
            )
        recording = None
        if rec_seg is not None and recorded:
            recording = WorkerRecording(
                rec_seg.buf, recorded, _all_outputs(runner),
                bridge.feeders if bridge is not None else [], runner.state,
                wait=self.simulated,
            )
        # control records (tunables, log levels, lifecycle): read only when one waits
        updates = self._updates()
        gate = updates.gate()
        feeders: list[Callable[[], object]] = [gate]
        if link is not None:
            feeders.insert(0, link.feeder)
        if bridge is not None:
            feeders += bridge.feeders
        watch = None
        timeout = self.settings.heartbeat_timeout
        if timeout > 0 and not self.simulated and not self.settings.use_sim_time:
            watch = heartbeat_watch(self._cells[2],
                                    max(2, round(timeout * self.settings.frequency)), self._stop())
            feeders.append(watch)
        try:
            if self.realtime is None:  # once per worker: scheduling, affinity, memory
                self.realtime = apply_realtime(self.settings, simulated=self.simulated)
            with FrozenGC(self.realtime):
                runner.start_components()  # before the loop (the outcome ring tells)
                self._send("event", "started", self.realtime.to_dict())
                self._in_loop = True
                if link is not None:
                    assert lane_run is not None
                    try:
                        link.stopped_here = False
                        link.begin(lane_run, *runner.time_grid, runner.resume_at, iterations)
                    except Aborted:  # stopped before every lane was ready
                        iterations = 0
                after: Callable[[], object] | None = _after_iteration(trace, bridge)
                if link is not None:
                    after = _chain(after, link.after)
                if link is not None:  # its loop ends where the lane's after() says
                    runner.stop_flag = link.decision
                try:
                    result = runner.run(
                        iterations,
                        timing_ring=ring,
                        on_iteration=after,
                        feeders=feeders,
                        # the supervisor's, with which it stamps the recording's timing
                        # rows
                        ros_offset_ns=ros_offset_ns,
                    )
                finally:
                    runner.stop_flag = self._stop()
            realtime = self.realtime.to_dict()
        except BaseException:
            if link is not None:
                link.failed()  # the other lanes stop too, through their safe stops
            raise
        finally:
            if link is not None and link.stopped_here:  # not a stop asked of this run
                self._stop().clear()
            self._in_loop = False
            gate.release()
            if watch is not None:
                watch.release()
            for name, value in self._parameters_set:
                self._send("event", "parameter_set", (name, value))
            self._parameters_set.clear()
            ring.close()
            seg.close()
            oversize = bridge.counts() if bridge else {}
            inputs = bridge.inputs() if bridge else {}
            record_counts = recording.counts() if recording is not None else {}
            if recording is not None:
                recording.release()  # before the bridge: it restores the bridge's taps
            if rec_seg is not None:
                rec_seg.close()
            if bridge is not None:
                bridge.release()
            if port_seg is not None:
                port_seg.close()
        if trace is not None and trace_path:
            trace.write(trace_path)
        if watch is not None and watch.fired:  # the supervisor may be gone: say it here too
            print(
                f"rtcf worker (pid {os.getpid()}): no sign of life from the supervisor for "
                f"{timeout:g} s (heartbeat_timeout) at iteration {runner.state.iteration}; "
                "stopped the loop through the safe stops",
                file=sys.stderr,
                flush=True,
            )
        return {
            "iterations": result.iterations,
            "stopped_by": result.stopped_by,
            "rows": result.timing.iterations,
            "overruns": result.timing.overruns,
            "order": result.order,
            "simulated": result.simulated,
            "realtime": realtime,
            "last_iteration": runner.state.iteration,
            "oversize": oversize,
            "inputs": inputs,
            "recording": record_counts,
            "faults": [f.to_dict() for f in result.faults],
            "safe_stops": [vars(o) for o in result.safe_stops],
            "deadlines": result.deadlines,
            "deadline_events": [e.to_dict() for e in result.deadline_events],
            "command_limits": result.command_limits,
            "heartbeat_lost": bool(watch is not None and watch.fired),
            "handovers": link.counts() if link is not None else {},
            "missed": runner.missed_releases,
        }

    def _stop(self) -> StopFlag:
        if self.stop is None:
            raise RtcfError("the worker has not been set up (no hello)")
        return self.stop

    def _updates(self) -> UpdateReader:
        if self.updates is None:
            raise RtcfError("the worker has not been set up (no hello)")
        return self.updates

    def shutdown(self) -> list[dict[str, Any]]:
        errors: list[dict[str, Any]] = []
        if self.runner is not None:
            errors = [error_to_dict(e) for e in self.runner.shutdown()]
            self.runner = None
        self.done = True
        return errors

    def close(self) -> None:
        self._release_lanes()
        if self.log_writer is not None:
            self.log_writer.release()
        if self._update_ring is not None:
            self._update_ring.close()
        if self._outcome_ring is not None:
            self._outcome_ring.close()
        if self.clock_box is not None:
            self.clock_box.close()
        for cell in getattr(self, "_cells", ()):
            cell.release()
        for seg in self.segments:
            seg.close()
        for bell in (self.doorbell, self.clock_doorbell):
            if bell is not None:
                bell.close()


def _all_outputs(runner: Runner) -> list[Any]:
    return [p for c in runner.components.values() for p in c._rtcf_outputs.values()]


def heartbeat_watch(cell: Any, limit: int, stop: StopFlag) -> HeartbeatWatch:
    """A feeder: ends the loop (ABORT, so the safe stops run) when the supervisor's
    heartbeat word has not moved for ``limit`` iterations. A read and a compare per
    iteration (in C where the hot path is compiled); the supervisor counts up every
    10 ms while the loop runs. ``release()`` it before the words go."""
    return HeartbeatWatch(cell, limit, stop.cell, ABORT)


def _chain(
    first: Callable[[], object] | None, second: Callable[[], object]
) -> Callable[[], object]:
    if first is None:
        return second

    def both() -> None:
        first()
        second()

    return both


def _after_iteration(
    trace: Trace | None, ports: WorkerPorts | None
) -> Callable[[], None] | None:
    """What runs after each iteration, outside its measured time: the trace's sample,
    and one ring of the supervisor's doorbell when a mapped output was written."""
    ring = ports.ring_if_pushed if ports is not None and ports.taps else None
    sample = trace.sample if trace is not None else None
    if sample is None or ring is None:
        return sample or ring

    def both() -> None:
        sample()
        ring()

    return both


PR_SET_PDEATHSIG = 1


def _follow_parent(supervisor_pid: int) -> None:
    """Get SIGTERM when the supervisor dies, so a lost worker never runs on alone."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):
        pass
    if os.getppid() != supervisor_pid:  # it died before the prctl took effect
        sys.exit(3)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        usage = f"usage: python -m {WORKER_MODULE} FD SUPERVISOR_PID (started by rtcf)"
        print(usage, file=sys.stderr)
        return 2
    fd, supervisor = int(args[0]), int(args[1])
    _follow_parent(supervisor)
    worker = Worker(Connection(fd))

    # Ctrl-C reaches the whole process group and a dying supervisor sends SIGTERM:
    # either way, end the loop after the iteration and let the hooks run
    def stop(signum: int, frame: FrameType | None) -> None:
        if worker.stop is not None:
            worker.stop.set(ABORT)  # not a normal stop: the safe_stop hooks run

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    try:
        return worker.serve()
    finally:
        worker.close()


if __name__ == "__main__":
    sys.exit(main())
