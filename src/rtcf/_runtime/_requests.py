"""Requests to a runner node (load, unload, activate, ...), served between two runs.

A middleware's service callbacks run in its threads; the worker's control channel
belongs to the main thread. So a callback queues a request, ends the current run
with ``request_control()`` and waits; the main thread serves what is queued and
runs the loop again. Shared by the ROS 1 and the ROS 2 rt_runner.

A lifecycle transition needs no stop: it reaches the running loop as an update
record (``WorkerRunner.change_state``). Only when no loop runs must the main thread
hand it over, so the queue wakes it with a ``sync`` request, which stops nothing.
The first ``configure`` of a component loaded unconfigured (ros2_control's
``load_controller``) declares its ports, so the graph is resolved again: asked for
from another thread (``_updates.queued_first_configure``), a ``configure`` request serves
it between two runs, as a load is, and answers once the supervisor knows the new
ports (``outcome``: the transition's).
"""

from __future__ import annotations

import queue
import signal
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .._core._errors import RtcfError
from .._core._executor import ABORT, STOP

if TYPE_CHECKING:
    from ._supervisor import WorkerRunner


def stop_on_signals(also: Callable[[], None] | None = None) -> threading.Event:
    """SIGINT and SIGTERM set the event returned (which stays set: a signal's stop is
    kept past the runner's clear_stop), and call ``also``. For the rt_runner and
    rt_launcher nodes of both middlewares."""
    asked = threading.Event()

    def handler(signum: int, frame: Any) -> None:
        asked.set()
        if also is not None:
            also()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    return asked


class Request:
    def __init__(self, kind: str, payload: Any) -> None:
        self.kind = kind
        self.payload = payload
        self.done = threading.Event()
        self.ok = False
        self.reason = ""
        self.abandoned = False  # its caller stopped waiting: not served any more
        self.outcome: Any = None  # a configure's TransitionOutcome


class RequestQueue:
    def __init__(self, runner: WorkerRunner) -> None:
        self._runner = runner
        self._queue: queue.Queue[Request] = queue.Queue()
        self._lock = threading.Lock()
        runner.wake_idle = self.poke
        runner.requests = self

    def submit(self, kind: str, payload: Any, timeout: float = 30.0) -> Request:
        """Queue a request and wait for the main thread to serve it (any thread)."""
        req = self.put(kind, payload)
        if not req.done.wait(timeout):
            with self._lock:
                req.abandoned = True
            req.reason = "the runner did not answer in time"
        return req

    def put(self, kind: str, payload: Any) -> Request:
        """Queue a request without waiting for it (a watch that unloads, say)."""
        req = Request(kind, payload)
        self._queue.put(req)
        self._runner.request_control()
        return req

    def poke(self) -> None:
        """Wake a main thread that waits here while no loop runs; the loop (if one has
        started meanwhile) is not stopped."""
        self._queue.put(Request("sync", None))

    def serve_until_stopped(
        self,
        serve: Callable[[Request], None],
        stopped: Callable[[], bool],
        run: Callable[[], None],
    ) -> None:
        """The main thread's loop: serve what is queued, run while the mode allows."""
        runner = self._runner
        while not stopped():
            # forget the last request's CONTROL *before* taking the requests: one that
            # comes after this sets it again, and the next run returns at once to serve
            # it (cleared after the queue was empty, its wake-up would be lost)
            runner.clear_stop()
            while self._serve_next(serve, None):
                pass
            if stopped() or runner.stop_reason in (STOP, ABORT):
                break
            if runner.describe()["not_ready"] is None:
                run()
            else:
                self._serve_next(serve, 0.1)
                if runner.transitions_pending:  # asked for while a run was ending
                    runner.sync()

    def _serve_next(self, serve: Callable[[Request], None], timeout: float | None) -> bool:
        try:
            req = self._queue.get(timeout=timeout) if timeout else self._queue.get_nowait()
        except queue.Empty:
            return False
        with self._lock:
            if req.abandoned:  # its caller gave up (and said so): do not act on it late
                return True
        serve(req)
        return True

    def refuse_pending(self, reason: str) -> None:
        """Answer what is still queued (shutting down), rather than leave it hanging."""
        while True:
            try:
                req = self._queue.get_nowait()
            except queue.Empty:
                return
            req.reason = reason
            req.done.set()


def serve_request(
    req: Request,
    runner: WorkerRunner,
    say: Callable[[str], None],
    load: Callable[[Any], str],
    unloaded: Callable[[str], str],
) -> None:
    """Serve one request on the main thread and answer it, whatever happens.

    ``load(payload)`` loads a component and returns the answer's text;
    ``unloaded(full_name)`` forgets an unloaded component's launcher and returns the
    answer's text. A refusal names the request and why; a malformed request never
    ends the runner.
    """
    try:
        if req.kind == "load":
            req.reason = load(req.payload)
        elif req.kind == "unload":
            full = req.payload if req.payload.startswith("/") else "/" + req.payload
            runner.unload(full)
            req.reason = unloaded(full)
            say(f"unloaded {full}")
        elif req.kind == "configure":  # a first configure: between two runs
            req.outcome = runner.change_state(req.payload, "configure")
        elif req.kind == "activate":
            runner.activate()
        elif req.kind == "deactivate":
            runner.deactivate()
        elif req.kind == "sync":  # lifecycle transitions wait in the update ring
            runner.sync()
        req.ok = True
    except RtcfError as exc:
        req.reason = str(exc)
        say(f"refused {req.kind}: {exc}")
    except Exception as exc:  # a malformed request must not end the runner
        req.reason = f"{type(exc).__name__}: {exc}"
        say(f"refused {req.kind}: {req.reason}")
    finally:
        req.done.set()

