"""The supervisor's runner: everything that is not real-time, with the same verbs as Runner.

:class:`WorkerRunner` is what the command line and the ROS runners hold: it loads,
tunes, runs and stops components whose loop runs in a worker process, and it is a
thin front to the collaborators that hold each part of that:

- :mod:`._worker_process`: the worker process (start, the control channel, death,
  its segments, the stop words);
- :mod:`._admission`: who may make requests (the lock, allowed_modules);
- :mod:`._loaded`: what is loaded, as tools see it (introspection);
- :mod:`._updates`: tunable values, log levels and lifecycle transitions for the
  worker, and the transitions' outcomes;
- :mod:`._runs`: one run of a worker (its timing, port channels and recording);
- :mod:`._lane_workers`: the other lanes' workers, and running every lane together;
- :mod:`._live_status`: the status line and diagnostics while the loop runs.

:class:`Bridge` is what a middleware bridge (ROS 2, ROS 1) implements for it.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from .._core._errors import RtcfError
from .._core._lane_names import MAIN_LANE
from .._core._lanes import lane_of
from .._core._lifecycle import TransitionOutcome
from .._core._log import LogRecord, PythonLoggingSink
from .._core._params import ParameterStore
from .._core._rings import Mailbox, Ring
from .._core._runner import ComponentSpec, RunResult
from .._core._settings import RunnerSettings
from .._core._timing import TimingAggregate
from ._admission import Admission
from ._doorbell import ClockFeed, Doorbell
from ._hardware_view import HardwareView
from ._heap import fill_numpy_cache
from ._lane_workers import LaneWorkers
from ._live_status import LiveReport, LiveStatus, live_aggregate, live_status_of
from ._loaded import LoadedComponents
from ._middleware import parameter_set
from ._port_channels import MailboxFanOut, MappedPort
from ._recording import RecordSink
from ._runs import RunChannels
from ._updates import WorkerUpdates, change_states, queued_first_configure
from ._worker_process import WorkerProcess, keep_off_cpus


class WorkerRunner:
    """A runner whose loop runs in a worker process; the same verbs as :class:`Runner`.

    The main lane's runner also starts a WorkerRunner per other lane (``lane``), and
    routes each component's requests to its lane's; a lane's worker publishes through
    the main lane's bridge (``outputs_bell``) and follows its /clock (``clock_feed``).
    """

    def __init__(
        self,
        settings: RunnerSettings,
        *,
        name: str = "rt_runner",
        parameters: ParameterStore | None = None,
        simulated: bool = False,
        log_level: str = "info",
        log_sink: Callable[[LogRecord], None] | None = None,
        log_capacity: int = 4096,
        on_status: Callable[[LiveStatus], None] | None = None,
        on_started: Callable[[dict[str, Any]], None] | None = None,
        bridge: Bridge | None = None,
        lane: str = MAIN_LANE,
        outputs_bell: Doorbell | None = None,
        clock_feed: ClockFeed | None = None,
    ) -> None:
        self.settings = settings
        self.name = name
        self.parameters = parameters if parameters is not None else ParameterStore()
        self.simulated = simulated
        self.log_level = log_level
        console = log_sink or PythonLoggingSink()
        self.log_sink = console if bridge is None else _both(console, bridge.log)
        self.log_capacity = log_capacity
        self.on_started = on_started
        self.bridge = bridge
        self._process = WorkerProcess(
            settings, name, pump=self.pump, on_poll=self._on_poll, on_event=self._on_event,
            kill=self.kill, label=self._lane_label,
        )
        self._report = LiveReport(on_status)
        # one lock for what the bridge's threads read and change: the loaded
        # components' entries, the updates for the worker, the transitions waited for
        self._update_lock = threading.Lock()
        self._loaded = LoadedComponents(self._update_lock)
        self.components = self._loaded.components  # as tools see them (one dict, kept)
        self._updates = WorkerUpdates(self._loaded)
        self.admission = Admission(settings, name, self._loaded)
        self.runs = RunChannels(
            self._process, self.call, settings, lane=lane, simulated=simulated,
            log_sink=self.log_sink, bridge=bridge,
            bridged=bridge is not None or outputs_bell is not None,
        )
        # wakes a main thread that waits for requests while no loop runs (RequestQueue)
        self.wake_idle: Callable[[], None] | None = None
        # an rt_runner's RequestQueue (loads while the loop runs; rtcf launch: none), and
        # its ros2_control YAML's section (_launch._controller_setup): load_controller's
        self.requests: Any = None
        self.controller_setup: Any = None
        self._owner = threading.get_ident()  # the thread of the control channel (start)
        # lanes: this worker's lane; the main lane's runner starts a worker per other
        # lane, routes each component's verbs to its lane, and runs them together
        self.lane = lane
        self._lanes: LaneWorkers[WorkerRunner] = LaneWorkers(
            settings, name, self.log_sink, start=self._start_lane,
            segment=self._process.segment, close_segment=self._process.close_segment,
        )
        # a lane's worker rings the main lane's bridge after pushing outputs to publish
        # and follows the /clock the main lane's bridge receives (use_sim_time)
        self.clock_feed = clock_feed
        self.outputs_bell = outputs_bell

    # -- process ---------------------------------------------------------------
    def start(self) -> WorkerRunner:
        self._owner = threading.get_ident()
        fill_numpy_cache()  # its growth would read as a leak in a long run
        if self.bridge is not None:
            self.bridge.configure(self.settings, self)
        process = self._process
        process.open_control()
        if self.settings.use_sim_time:
            if self.bridge is None and self.clock_feed is None:
                raise RtcfError(
                    f"runner {self.name!r}: use_sim_time needs a middleware that publishes "
                    "/clock; run with --middleware ros2"
                )
            mine = process.open_clock()
            if self.clock_feed is None:  # the main lane: the bridge's /clock feeds it
                assert self.bridge is not None
                self.clock_feed = ClockFeed()
                self.bridge.follow_clock(self.clock_feed)
            self.clock_feed.add(mine)
        process.open_log(self.log_capacity)
        updates = self._updates.open(process.segment)
        bell_of = self.bridge.doorbell if self.bridge is not None else self.outputs_bell
        bell = bell_of.fd if bell_of is not None else -1
        process.spawn(bell)
        hello = self.call(
            "hello", list(sys.path), process.control, process.log, updates, self.settings,
            self.parameters.as_dict(), self.name, self.simulated, self.log_level, bell,
            process.clock_bell_fd,
        )
        # what the worker built of the robot description: the controller manager's view
        self.hardware = HardwareView(
            hello.get("hardware", []), self.transition_listeners, self.admission,
            self._updates, self._hand_over, self.introspect)
        self.refresh_introspection()
        return self

    @property
    def process(self) -> subprocess.Popen[bytes] | None:
        return self._process.process

    @property
    def pid(self) -> int | None:
        return self._process.pid

    def __enter__(self) -> WorkerRunner:
        return self.start() if self.process is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the control channel -----------------------------------------------------
    def call(self, command: str, *args: Any) -> Any:
        """Send a command and wait for its answer, draining the rings meanwhile."""
        self._report.begin()
        return self._process.call(command, *args)

    def _call_all(self, command: str, *args: Any) -> None:
        """A command for this worker, then for every other lane's."""
        self.call(command, *args)
        for worker in self._lanes.workers.values():
            worker.call(command, *args)

    def _on_poll(self) -> None:
        """Every polling interval of a command: the status line and diagnostics."""
        if self.runs.running:
            diagnostics = self._diagnostics if self.bridge is not None else None
            self._report.poll(self.live_status, diagnostics)

    def _diagnostics(self, status: LiveStatus) -> None:
        assert self.bridge is not None
        self.bridge.diagnostics(self.name, status, self._live_aggregate())

    def _on_event(self, event: str, payload: Any) -> None:
        if event == "parameter_set":  # a component's params.set(): kept, and told
            self.parameters.set(*payload)
            parameter_set(self.bridge, self.log_sink, *payload)
        elif event == "started":
            self._on_started(payload)

    def kill(self) -> None:
        """Kill the worker at once (SIGKILL): no hook runs any more."""
        for worker in self._lanes.workers.values():
            worker.kill()
        self._process.kill()

    def _lane_label(self) -> str:
        """Which lane a worker's death message names: none when no lanes run."""
        return f"lane {self.lane!r}: " if self.lane != MAIN_LANE or self._lanes.workers else ""

    # -- draining ------------------------------------------------------------------
    def pump(self) -> None:
        """Drain log records and timing rows (non-real-time work, called often)."""
        self._process.drain_log(self.log_sink)
        self.runs.drain()
        self._updates.pump()

    @property
    def log_records_dropped(self) -> int:
        return self._process.log_records_dropped

    def _live_aggregate(self) -> TimingAggregate:
        """The run's timing so far: with lanes the loop's as a whole."""
        return live_aggregate(self.runs.aggregate, self._lanes.span)

    def live_status(self) -> LiveStatus:
        return live_status_of(self)

    def past_deadline(self) -> tuple[tuple[str, ...], int]:
        """The inputs past their deadline now, by name, and how many times any passed
        it: this worker's, then every other lane's."""
        bits, misses = self._process.deadline_words
        names = self.runs.deadline_names
        past = tuple(n for k, n in enumerate(names[:63]) if bits >> k & 1)
        for lane in self._lanes.workers.values():
            more, their_misses = lane.past_deadline()
            past, misses = past + more, misses + their_misses
        return past, misses

    # -- the runner's verbs ------------------------------------------------------
    def admits(self, what: str, module: str | None = None, component: str | None = None,
               class_name: str | None = None) -> None:
        """RequestRefused if the runner would refuse the request (:meth:`Admission.admits`)."""
        self.admission.admits(what, module, component, class_name)

    @property
    def locked(self) -> bool:
        """Whether the runner's lock applies (once its loop has run)."""
        return self.admission.locked

    @property
    def introspection(self) -> dict[str, Any]:
        return self._loaded.introspection

    @property
    def transition_listeners(self) -> list[Callable[[str, TransitionOutcome], None]]:
        """Told every transition a component went through (a bridge: transition events)."""
        return self._updates.listeners

    @transition_listeners.setter
    def transition_listeners(self, listeners: list[Callable[[str, TransitionOutcome], None]]
                             ) -> None:
        self._updates.listeners = listeners

    def load(self, spec: ComponentSpec, *, launcher: str = "", refresh: bool = True) -> str:
        """Load a component into its lane's worker. ``refresh=False``: leave the
        introspection (the order and the graph over all components) for one
        :meth:`refresh_introspection` after a batch of loads (a launch file's: once per
        load, a thousand components took 20 s)."""
        # before the worker imports it
        self.admission.refuse_module(
            spec.cls.__module__ if spec.cls is not None else spec.module, spec.full_name
        )
        self.admission.refuse_if_locked("loads")
        lane = lane_of(spec.lane)
        if lane != self.lane and self.lane == MAIN_LANE:  # another lane's worker loads it
            worker = self._lanes.worker(lane)
            full = worker.load(spec, launcher=launcher, refresh=refresh)
            with self._update_lock:
                info = self.components[full] = worker.components[full]
                self._lanes.lane_of[full] = lane
        else:
            if spec.cls is not None:
                # the worker imports the class by name, as an rt_launcher would ask for it
                spec = dataclasses.replace(
                    spec, cls=None, module=spec.cls.__module__, class_name=spec.cls.__qualname__
                )
            info = dict(self.call("load", spec))
            info["launcher"] = launcher
            full = str(info["name"])
            with self._update_lock:
                self.components[full] = info
        if refresh:
            self.refresh_introspection()
        if self.bridge is not None:
            self.bridge.component_loaded(info, self)
        return full

    def set_parameters(self, values: dict[str, Any]) -> None:
        """Set absolute parameters in the worker's tree (components read them at
        configure): a middleware's parameter server, fetched before a load."""
        for name, value in values.items():
            self.parameters.set(name, value)
        self._call_all("set_parameters", values)

    def unload(self, name: str) -> None:
        self.admission.refuse_if_locked("unloads")
        full = name if name.startswith("/") else "/" + name
        owner = self._owner_of(full)
        if owner is not self:
            owner.unload(full)
            with self._update_lock:
                self.components.pop(full, None)
                self._lanes.lane_of.pop(full, None)
        else:
            self.call("unload", full)
            self._updates.unloaded(full)
        self.refresh_introspection()
        if self.bridge is not None:
            self.bridge.component_unloaded(full)

    def refresh_introspection(self) -> dict[str, Any]:
        if self._lanes.workers:  # the order over every lane's components
            try:
                self._lanes.sync(self, mirror=False)
            except RtcfError:
                pass  # the introspection's "problem" says it
        data = dict(self.call("introspect"))
        data["runner"] = self.name
        self._loaded.publish(self._lanes.merge_introspection(data))
        return data

    def introspect(self) -> dict[str, Any]:
        """The last introspection data, with the current tunable values and log levels,
        and the inputs past their deadline now."""
        data = self._loaded.introspect()
        data["past_deadline"] = list(self.past_deadline()[0])
        return data

    # -- tuning while running (any thread) ---------------------------------------
    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        """Validate a new value here, then hand it to the worker for the next iteration."""
        self.admission.refuse_if_locked("changes of tunable parameters", ("all",))
        owner = self._owner_of(component)
        if owner is not self:
            return owner.set_parameter(component, name, value)
        return self._updates.set_parameter(component, name, value)

    def set_log_level(self, component: str, level: int | str) -> None:
        """Filter the component's records in the worker from the next iteration on."""
        owner = self._owner_of(component)
        if owner is not self:
            owner.set_log_level(component, level)
            return
        self._updates.set_log_level(component, level)

    # -- lifecycle (any thread) ------------------------------------------------------
    def lifecycle_state(self, component: str) -> str:
        """A component's lifecycle state as last reported by the worker."""
        return str(self._loaded.find(component).get("lifecycle", "unknown"))

    def change_state(
        self, component: str, transition: int | str, timeout: float | None = None
    ) -> TransitionOutcome:
        """Ask for a component's lifecycle transition and wait for its outcome.

        It crosses to the worker as an update record, like a parameter change, and the
        loop applies it at the start of its next iteration (between runs: before the
        worker's next command). The answer comes back on the outcome ring. The loop
        goes on meanwhile. Waiting longer than ``timeout`` (default: 10 s and three
        periods) gives up with a refusal; the transition may still happen later (the
        listeners hear of it then).
        """
        return self.change_states([(component, transition)], timeout)[0]

    def change_states(
        self, transitions: Sequence[tuple[str, int | str]], timeout: float | None = None,
        strict: bool = False,
    ) -> list[TransitionOutcome]:
        """Several transitions at once (a controller manager's switch): each worker
        applies its components' at the start of one iteration, in the order given
        (``strict``: all or none, rtcf._core._switching); the outcomes come in that order."""
        self.admission.refuse_if_locked("lifecycle transitions")
        queued = queued_first_configure(self.requests, self.components, transitions,
                                        threading.get_ident() == self._owner)
        if queued is not None:  # a first configure: served between two runs, as a load
            return [queued]
        asked = []
        for component, transition in transitions:
            owner = self._owner_of(component)
            full = str(owner._loaded.find(component)["name"])
            asked.append((owner._updates, owner._hand_over, full, transition))
        outcomes = change_states(asked, 10.0 + 3.0 / self.settings.frequency
                                 if timeout is None else timeout, strict)
        if threading.get_ident() == self._owner and not self.loop_running:
            self._configured()  # (else before the next run)
        return outcomes

    def _configured(self) -> None:
        """Describe again what first configures declared (main thread, no loop running)."""
        tell = getattr(self.bridge, "component_configured", None)  # (ROS 2's)
        described = [(worker, full) for worker in (self, *self._lanes.workers.values())
                     for full in worker._updates.take_configured()]
        for worker, full in described:
            info = worker._loaded.replace(full, worker.call("describe_component", full))
            if info is not None and tell is not None:
                tell(info, self)
        if described:
            self.refresh_introspection()

    def _hand_over(self) -> None:
        """A transition waits: when no loop reads the record, the main thread hands it
        over (or is woken to)."""
        if not self.loop_running:
            if threading.get_ident() == self._owner:
                self.sync()
            elif self.wake_idle is not None:
                self.wake_idle()

    @property
    def transitions_pending(self) -> bool:
        """Whether a transition waits for the worker (the main thread should sync)."""
        return bool(self._updates.pending) or any(
            w._updates.pending for w in self._lanes.workers.values()
        )

    @property
    def loop_running(self) -> bool:
        return self.runs.running

    def sync(self) -> None:
        """Have the worker apply what waits for it, when no loop runs (main thread)."""
        self._call_all("sync")
        self._configured()  # a first configure among them: its ports described now

    def activate(self) -> None:
        self._call_all("activate")

    def deactivate(self) -> None:
        self._call_all("deactivate")

    def describe(self) -> dict[str, Any]:
        if self._lanes.workers:
            self._lanes.sync(self, mirror=False)
        out = dict(self.call("describe"))
        return self._lanes.merge_described(out)

    def request_stop(self, *, abort: bool = False) -> None:
        """End the loop after the current iteration (safe from a signal handler).

        ``abort``: not a normal stop (a signal): the components' safe_stop hooks run.
        """
        self._process.request_stop(abort)
        # a normal stop reaches the other lanes through the main lane, unless they
        # sleep until /clock moves (which may have stopped): then it wakes them too
        if abort or self.settings.use_sim_time:
            for worker in self._lanes.workers.values():
                worker.request_stop(abort=abort)

    def request_control(self) -> None:
        """End the loop after the iteration so a request can be served (it resumes after)."""
        self._process.request_control()
        if self.settings.use_sim_time:  # lanes asleep until /clock moves
            for worker in self._lanes.workers.values():
                worker.request_control()

    @property
    def stop_reason(self) -> int:
        return self._process.stop_reason

    def clear_stop(self) -> None:
        """Forget a stop request (the next run runs); a stop asked for earlier sticks."""
        self._process.clear_stop()
        for worker in self._lanes.workers.values():
            worker.clear_stop()

    def run(
        self,
        iterations: int | None = None,
        *,
        trace: str | None = None,
        record: RecordSink | None = None,
    ) -> RunResult:
        """Run the loop in the worker until ``iterations`` ran or :meth:`request_stop`;
        with ``record``, every value of the topics it selects goes into it. With lanes,
        every lane's worker runs it, together."""
        self._configured()
        if any(w.components for w in self._lanes.workers.values()):
            return self._lanes.run(
                self, iterations, trace, record, bridge=self.bridge,
                ros_offset=self.runs.ros_offset(),
            )
        return self.runs.run(iterations, trace, record)

    def _on_started(self, realtime: dict[str, Any]) -> None:
        self._report.started()
        self.admission.loop_started(self.lane)
        if self.settings.cpu_affinity_mask:
            keep_off_cpus(realtime.get("cpu_affinity") or [])
        if self.on_started is not None:
            self.on_started(realtime)

    def shutdown(self) -> list[RtcfError]:
        """Stop and clean up every component in the worker, then let it exit."""
        errors = []
        for worker in self._lanes.workers.values():
            errors += worker.shutdown()
        return errors + self._process.shutdown()

    def close(self) -> None:
        """Make sure the worker is gone and every segment is unmapped and removed."""
        for worker in self._lanes.workers.values():
            worker.close()
        self._lanes.close()
        if self.bridge is not None:
            self.bridge.shutdown()
            self.bridge = None
        self._process.end(self.request_stop)
        self._process.release_words()
        self._updates.close()
        self._process.release()

    # -- lanes ----------------------------------------------------------------------
    @property
    def lanes(self) -> LaneWorkers[WorkerRunner]:
        """The other lanes' workers: where each runs (``placement``, ``said``), and
        whether starting one is said at info level (``say``)."""
        return self._lanes

    def _owner_of(self, component: str) -> WorkerRunner:
        return self._lanes.worker_of(component) or self

    def _start_lane(self, lane: str, settings: RunnerSettings) -> WorkerRunner:
        """A worker for lane ``lane`` (pinned by ``settings``): it publishes through
        this runner's bridge, follows its /clock, tells its transition listeners."""
        worker = WorkerRunner(
            settings,
            name=self.name,
            parameters=self.parameters,
            simulated=self.simulated,
            log_level=self.log_level,
            log_sink=self.log_sink,
            log_capacity=self.log_capacity,
            lane=lane,
            outputs_bell=self.bridge.doorbell if self.bridge is not None else None,
            clock_feed=self.clock_feed,
        )
        worker.transition_listeners = self.transition_listeners
        return worker.start()


class Bridge(Protocol):
    """A middleware bridge in the supervisor (ROS 2, ROS 1): topics for mapped ports."""

    doorbell: Doorbell  # the worker rings it after each record it pushed for the bridge

    def configure(self, settings: RunnerSettings, runner: WorkerRunner) -> None:
        """The runner's settings (QoS, iteration_info) and what introspection asks,
        before anything else."""

    def open(
        self, ports: list[MappedPort], channels: Mapping[str, Ring | Mailbox | MailboxFanOut]
    ) -> None: ...

    def iteration_info(self, rows: Any) -> None:
        """Timing rows as they are drained (numpy int64, one row per iteration)."""

    def close_run(self) -> None: ...

    def log(self, rec: LogRecord) -> None: ...

    def follow_clock(self, box: ClockFeed) -> None: ...

    def component_loaded(self, info: dict[str, Any], runner: WorkerRunner) -> None:
        """A component was loaded: show it (a node of its own name, its parameters)."""

    def component_unloaded(self, name: str) -> None: ...

    def diagnostics(
        self, runner: str, status: LiveStatus, aggregate: TimingAggregate
    ) -> None: ...

    def shutdown(self) -> None: ...


def _both(
    first: Callable[[LogRecord], None], second: Callable[[LogRecord], None]
) -> Callable[[LogRecord], None]:
    def sink(rec: LogRecord) -> None:
        first(rec)
        second(rec)

    return sink
