"""The supervisor's side of one worker process: start, the control channel, death.

:class:`WorkerProcess` starts ``python -m rtcf._runtime._worker``, hands it the
segments every worker needs from its start (the control words, /clock's mailbox,
the log ring) and sends it commands over a Unix socket between runs, draining what
the worker writes while it waits. It owns every segment of its worker: anonymous
memory (memfd) handed over as a file descriptor, so there is no name that could be
left behind whatever way either process ends (SIGKILL included). A worker that dies,
or a hook that does not return within hook_timeout, is noticed within a polling
interval and said as a :class:`WorkerDied`: which worker, how, and what it ran.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

from .._core._errors import RtcfError
from .._core._executor import ABORT, CONTROL, STOP
from .._core._log import LOG_RECORD_SIZE, LogRecord, drain_channel
from .._core._rings import Mailbox, Ring
from .._core._settings import RunnerSettings
from .._core._timing import FIXED_COLUMNS, TimingAggregate
from ._doorbell import Doorbell, RungMailbox
from ._shm import Segment, outgoing, send_segments
from ._worker import (
    CLOCK_MAILBOX_OFFSET,
    CTL_COMMANDS_CLAMPED,
    CTL_COMMANDS_REFUSED,
    CTL_DEADLINE_MISSES,
    CTL_DEADLINES,
    CTL_FAULTS,
    CTL_HEARTBEAT,
    CTL_RUNNING,
    CTL_STOP,
    WORKER_MODULE,
    error_from_dict,
)

POLL_S = 0.01  # how often the supervisor drains while it waits for the worker


class WorkerDied(RtcfError):
    """The worker process ended without being asked to."""


def worker_env() -> dict[str, str]:
    env = dict(os.environ)
    # the worker must find this very rtcf even when it is not installed
    src = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH", "")) if p)
    # a component that imports numpy must not start BLAS worker threads beside the loop
    for key in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(key, "1")
    return env


def keep_off_cpus(worker_cpus: list[int]) -> None:
    """Move the supervisor off the worker's CPUs when that leaves it somewhere to run."""
    try:
        mine = os.sched_getaffinity(0)
        rest = mine - set(worker_cpus)
        if worker_cpus and rest and rest != mine:
            os.sched_setaffinity(0, rest)
    except OSError:
        pass



class WorkerProcess:
    """One worker process and its control channel, seen from the supervisor.

    What happens while a command waits is the runner's, told as callables: ``pump``
    drains the rings (called every polling interval and after each answer),
    ``on_poll`` runs every polling interval (the status line, diagnostics),
    ``on_event`` hears the worker's events but its hooks ("started",
    "parameter_set"), ``kill`` kills this worker and its siblings (a hung hook takes
    the whole runner down), ``label`` says which lane, if lanes run.
    """

    def __init__(
        self,
        settings: RunnerSettings,
        name: str,
        *,
        pump: Callable[[], None],
        on_poll: Callable[[], None],
        on_event: Callable[[str, Any], None],
        kill: Callable[[], None],
        label: Callable[[], str],
    ) -> None:
        self.settings = settings
        self.name = name
        self.pump = pump
        self.on_poll = on_poll
        self.on_event = on_event
        self._kill_all = kill
        self.label = label
        self.process: subprocess.Popen[bytes] | None = None
        self.conn: Connection | None = None
        self.segments: list[Segment] = []
        self.control: Segment | None = None
        self.ctl: memoryview | None = None  # the control words (heartbeat, stop, ...)
        self.clock_box: Mailbox | None = None
        self.clock_bell: Doorbell | None = None  # rung with each /clock message
        self.log: Segment | None = None
        self.log_ring: Ring | None = None
        # the run's schedule and timing while a loop runs: what a death message names
        self.running: tuple[list[str], TimingAggregate] | None = None
        self.hook: tuple[str, str, float] | None = None  # the hook the worker runs now
        self.exit_reported = False

    # -- start ------------------------------------------------------------------
    def open_control(self) -> None:
        """The control words, with room for /clock's mailbox after them."""
        control = self.segment(CLOCK_MAILBOX_OFFSET + Mailbox.nbytes(8), "rtcf-control")
        self.control = control
        self.ctl = control.buf[:CLOCK_MAILBOX_OFFSET].cast("q")

    def open_clock(self) -> RungMailbox:
        """/clock's mailbox for this worker, and the doorbell rung with each message."""
        assert self.control is not None
        clock_view = self.control.buf[CLOCK_MAILBOX_OFFSET:]
        self.clock_box = Mailbox.create(clock_view, 8)
        clock_view.release()
        self.clock_bell = Doorbell.create()
        return RungMailbox(self.clock_box, self.clock_bell)

    def open_log(self, capacity: int) -> None:
        log = self.log = self.segment(Ring.nbytes(capacity, LOG_RECORD_SIZE), "rtcf-log")
        self.log_ring = Ring.create(log.buf, capacity, LOG_RECORD_SIZE)

    def spawn(self, bell: int) -> None:
        """Start the worker: its end of the control channel, the bridge's doorbell
        (``bell``, or -1) and /clock's are inherited file descriptors."""
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        # blocking whatever socket.setdefaulttimeout() says: rospy sets a process-wide
        # timeout, which makes new sockets non-blocking underneath, and the worker would
        # read EAGAIN on its control channel as the end of it
        ours.setblocking(True)
        theirs.setblocking(True)
        clock_bell = self.clock_bell_fd
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-m", WORKER_MODULE, str(theirs.fileno()), str(os.getpid())],
                pass_fds=tuple(fd for fd in (theirs.fileno(), bell, clock_bell) if fd >= 0),
                stdin=subprocess.DEVNULL,
                env=worker_env(),
            )
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())

    @property
    def clock_bell_fd(self) -> int:
        return self.clock_bell.fd if self.clock_bell is not None else -1

    def segment(self, size: int, name: str) -> Segment:
        seg = Segment.create(size, name)
        self.segments.append(seg)
        return seg

    def close_segment(self, seg: Segment) -> None:
        seg.close()
        self.segments.remove(seg)

    @property
    def pid(self) -> int | None:
        return self.process.pid if self.process else None

    # -- the control channel -----------------------------------------------------
    def call(self, command: str, *args: Any) -> Any:
        """Send a command and wait for its answer, draining the rings meanwhile."""
        conn = self._conn()
        args, segments = outgoing(args)
        try:
            conn.send((command, args))
            send_segments(conn, segments)
        except (BrokenPipeError, ConnectionResetError, OSError):
            raise self.died(f"while sending {command!r}") from None
        for seg in segments:  # the worker's copy is in flight or mapped: ours can go
            seg.close_fd()
        self.hook = None
        while True:
            try:
                ready = conn.poll(POLL_S)
            except (EOFError, OSError):
                ready = True
            if self.ctl is not None:
                self.ctl[CTL_HEARTBEAT] += 1  # a sign of life for the worker's watch
            self.pump()
            if self.hook is not None and not ready:
                component, hook, since = self.hook
                if time.monotonic() - since > self.settings.hook_timeout:
                    raise self._hung(component, hook)
            self.on_poll()
            if not ready:
                if self.process is not None and self.process.poll() is not None:
                    raise self.died(f"during {command!r}")
                continue
            try:
                message = conn.recv()
            except (EOFError, OSError):
                raise self.died(f"during {command!r}") from None
            kind = message[0]
            if kind == "event":
                if message[1] == "hook":
                    component, hook = message[2]
                    self.hook = (component, hook, time.monotonic())
                    continue
                if message[1] == "started":
                    self.hook = None  # the loop runs: its time is the watchdogs' business
                    # the components' starts are in the outcome ring already: whoever
                    # hears "started" sees them active
                    self.pump()
                self.on_event(message[1], message[2])
                continue
            self.pump()
            if kind == "error":
                raise error_from_dict(message[1])
            return message[1]

    def _conn(self) -> Connection:
        if self.conn is None:
            raise RtcfError("the worker process is not running; call start() first")
        return self.conn

    # -- the control words -----------------------------------------------------------
    def request_stop(self, abort: bool) -> None:
        """Set the stop word (an abort is never turned back into a stop)."""
        if self.ctl is not None:
            if abort or self.ctl[CTL_STOP] != ABORT:
                self.ctl[CTL_STOP] = ABORT if abort else STOP
            self._wake_clock()

    def request_control(self) -> None:
        if self.ctl is not None and self.ctl[CTL_STOP] not in (STOP, ABORT):
            self.ctl[CTL_STOP] = CONTROL
            self._wake_clock()

    def _wake_clock(self) -> None:
        """A loop waiting for /clock time sees the stop word at once."""
        bell = self.clock_bell
        if bell is not None and bell.fd >= 0:
            bell.ring()

    def clear_stop(self) -> None:
        if self.ctl is not None:
            self.ctl[CTL_STOP] = 0

    @property
    def stop_reason(self) -> int:
        return self.ctl[CTL_STOP] if self.ctl is not None else 0

    @property
    def faults(self) -> int:
        """Component failures a policy contained (on_error deactivate/restart)."""
        return self.ctl[CTL_FAULTS] if self.ctl is not None else 0

    @property
    def deadline_words(self) -> tuple[int, int]:
        """Inputs past their deadline now (a bit each), and how many times any passed it."""
        if self.ctl is None:
            return 0, 0
        return self.ctl[CTL_DEADLINES], self.ctl[CTL_DEADLINE_MISSES]

    @property
    def command_words(self) -> tuple[int, int]:
        """Commands the hardware's limits clamped so far, and those they refused."""
        if self.ctl is None:
            return 0, 0
        return self.ctl[CTL_COMMANDS_CLAMPED], self.ctl[CTL_COMMANDS_REFUSED]

    def drain_log(self, sink: Callable[[LogRecord], None]) -> None:
        if self.log_ring is not None:
            drain_channel(self.log_ring, sink)

    @property
    def log_records_dropped(self) -> int:
        return self.log_ring.dropped if self.log_ring is not None else 0

    # -- death ------------------------------------------------------------------
    def _hung(self, component: str, hook: str) -> WorkerDied:
        """A hook did not return within hook_timeout: kill the worker and say which."""
        limit = self.settings.hook_timeout
        self._kill_all()
        self.pump()
        self.exit_reported = True
        return WorkerDied(
            f"runner {self.name!r}: component {component!r}: {hook}() did not return within "
            f"{limit:g} s (hook_timeout); the worker process (pid {self.pid}) was killed, so "
            "the hooks after it did not run; raise hook_timeout if it needs longer"
        )

    def kill(self) -> None:
        """Kill the worker at once (SIGKILL): no hook runs any more."""
        proc = self.process
        if proc is not None and proc.poll() is None:
            proc.kill()
            try:
                proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                pass

    def _running_now(self) -> str:
        """What the worker was doing, from the running word and the last hook event."""
        if self.hook is not None:
            return f" while {self.hook[0]}'s {self.hook[1]}() was running"
        if self.ctl is None or self.running is None:
            return ""
        column = self.ctl[CTL_RUNNING]
        schedule = self.running[0]
        if FIXED_COLUMNS <= column < FIXED_COLUMNS + len(schedule):
            return f" while {schedule[column - FIXED_COLUMNS]}'s update() was running"
        return ""

    def died(self, when: str) -> WorkerDied:
        proc = self.process
        code = None
        if proc is not None:
            try:
                code = proc.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                code = None
        if code is not None and code < 0:
            how = f"was killed by {signal.Signals(-code).name}"
        elif code is not None:
            how = f"exited with status {code}"
        else:
            how = "stopped answering"
        self.pump()
        where = ""
        if self.running is not None:
            where = f" after iteration {self.running[1].last_iteration}"
        where += self._running_now()
        self.exit_reported = True
        return WorkerDied(
            f"runner {self.name!r}: {self.label()}the worker process (pid {self.pid}) {how} "
            f"{when}{where}; the components' stop() and cleanup() did not run"
        )

    # -- the end ------------------------------------------------------------------
    def shutdown(self) -> list[RtcfError]:
        """Stop and clean up every component in the worker, then let it exit; the
        errors of their stop() and cleanup()."""
        proc = self.process
        if self.conn is None or proc is None or proc.poll() is not None:
            return []
        errors = [error_from_dict(d) for d in self.call("shutdown")]
        try:
            proc.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            pass
        return errors

    def end(self, request_stop: Callable[[], None]) -> None:
        """End of file on its control channel: the worker cleans up its components and
        leaves (a loop still running is stopped first, by ``request_stop``); wait for it."""
        proc = self.process
        if self.conn is not None:
            request_stop()
            self.conn.close()
            self.conn = None
        if proc is not None and proc.poll() is None:
            try:
                proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                proc.terminate()
                try:
                    proc.wait(timeout=2.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()

    def release_words(self) -> None:
        """Let go of the control words and the log ring (the worker is gone)."""
        if self.ctl is not None:
            self.ctl.release()
            self.ctl = None
        if self.log_ring is not None:
            self.log_ring.close()
            self.log_ring = None

    def release(self) -> None:
        """Let go of /clock's mailbox and doorbell and unmap every segment left."""
        if self.clock_box is not None:
            self.clock_box.close()
            self.clock_box = None
        if self.clock_bell is not None:
            self.clock_bell.close()
        for seg in list(self.segments):
            self.close_segment(seg)
