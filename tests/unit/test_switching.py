"""A switch's transitions (a controller manager's ``switch_controller``) applied together
between two iterations, in-process on a SimClock and through the worker's update ring
as a supervisor sends them (rtcf._core._switching, rtcf._runtime._worker_updates):
STRICT is all or nothing in the iteration the switch lands in, so no iteration runs
with the switch half made; BEST_EFFORT makes what it can."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

import rtcf
from rtcf._core._clock import SimClock
from rtcf._core._lifecycle import UNDONE
from rtcf._core._rings import Ring
from rtcf._core._runner import ComponentSpec, Runner
from rtcf._core._settings import RunnerSettings
from rtcf._core._tunables import UPDATE_RING_RECORDS, UpdateReader
from rtcf._runtime._loaded import LoadedComponents
from rtcf._runtime._shm import Segment
from rtcf._runtime._updates import WorkerUpdates
from rtcf._runtime._worker_updates import UpdateApplier


class Controller(rtcf.Component):
    """Writes the iteration to ``/command`` (claimed by nobody: the test reads who ran)."""

    refuse = False

    def configure(self) -> None:
        self.ran: list[int] = []

    def start(self) -> bool:
        return not self.refuse

    def update(self) -> None:
        self.ran.append(self.iteration)


class Refuser(Controller):
    refuse = True


def runner(log: list[str] | None = None) -> Runner:
    sink = (lambda rec: log.append(rec.format())) if log is not None else None
    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock(), log_sink=sink)
    r.load(ComponentSpec("standby", cls=Controller))
    r.load(ComponentSpec("teleop", cls=Controller, autostart=False))
    r.load(ComponentSpec("refuser", cls=Refuser, autostart=False))
    return r


def ran(r: Runner, name: str) -> list[int]:
    return r.components[name].ran  # type: ignore[attr-defined, no-any-return]


SWITCH = [("/standby", "deactivate"), ("/teleop", "activate"), ("/refuser", "activate")]


@pytest.fixture
def worker() -> Iterator[tuple[WorkerUpdates, Runner, UpdateReader, list[str]]]:
    """The supervisor's WorkerUpdates; the worker's runner, and its reader of the update
    ring (the loop's feeder), answering on the outcome ring."""
    loaded = LoadedComponents(threading.Lock())
    for name in ("/standby", "/teleop", "/refuser"):
        loaded.components[name] = {"name": name, "lifecycle": "inactive"}
    updates = WorkerUpdates(loaded)
    segment = updates.open(lambda size, name: Segment.create(size))
    incoming = Ring.open(segment.buf)
    outgoing = Ring.open(segment.buf[Ring.nbytes(UPDATE_RING_RECORDS, incoming.record_size):])
    log: list[str] = []
    r = runner(log)
    reader = UpdateReader(incoming, UpdateApplier(r, outgoing).apply)
    yield updates, r, reader, log
    r.shutdown()
    incoming.close()
    outgoing.close()
    updates.close()
    segment.close()


def test_a_strict_switch_that_fails_leaves_no_iteration_with_the_switch_half_made(
    worker: tuple[WorkerUpdates, Runner, UpdateReader, list[str]],
) -> None:
    updates, r, reader, log = worker
    r.run(2, feeders=[reader])
    asked = updates.send_transitions(SWITCH, strict=True)  # lands at iteration 2
    r.run(3, feeders=[reader])
    updates.pump()  # the answers
    # standby ran in every iteration, teleop in none: not one with the switch half made
    assert ran(r, "/standby") == [0, 1, 2, 3, 4]
    assert ran(r, "/teleop") == []
    assert [r.lifecycle_state(n) for n, _ in SWITCH] == ["active", "inactive", "inactive"]
    answers = [pending.outcome for _, pending in asked]
    assert all(a is not None for a in answers)
    standby, teleop, refuser = answers  # type: ignore[misc]
    assert (refuser.result, refuser.reason) == ("failure", "start() returned False")
    assert standby.result == teleop.result == UNDONE
    assert (standby.start, standby.end) == (3, 3)  # active, and active again
    assert teleop.reason.startswith("undone: the STRICT switch failed at 'activate' of "
                                    "'/refuser'")
    # the supervisor's view: the states as they are, told once each
    assert updates.loaded.components["/standby"]["lifecycle"] == "active"
    assert updates.loaded.components["/teleop"]["lifecycle"] == "inactive"
    r.drain_logs()
    [line] = [t for t in log if "switch: " in t]
    assert line.endswith(
        "switch: the STRICT switch failed at 'activate' of '/refuser' (activate: inactive -> "
        "inactive (failure): start() returned False); undone in the same iteration: "
        "/teleop deactivated again, /standby activated again"), line


def test_a_strict_switch_that_succeeds_and_a_best_effort_one_land_in_one_iteration(
    worker: tuple[WorkerUpdates, Runner, UpdateReader, list[str]],
) -> None:
    updates, r, reader, _ = worker
    r.run(2, feeders=[reader])
    asked = updates.send_transitions(SWITCH[:2], strict=True)
    r.run(2, feeders=[reader])
    updates.pump()
    assert [p.outcome.ok for _, p in asked] == [True, True]  # type: ignore[union-attr]
    assert (ran(r, "/standby"), ran(r, "/teleop")) == ([0, 1], [2, 3])
    assert updates.loaded.components["/teleop"]["lifecycle"] == "active"
    # BEST_EFFORT: the failed one is left out, the rest is made
    asked = updates.send_transitions(
        [("/teleop", "deactivate"), ("/standby", "activate"), ("/refuser", "activate")])
    r.run(1, feeders=[reader])
    updates.pump()
    assert [p.outcome.ok for _, p in asked] == [True, True, False]  # type: ignore[union-attr]
    assert (ran(r, "/standby")[-1], ran(r, "/teleop")[-1]) == (4, 3)


def test_the_in_process_runner_switches_all_or_nothing_too() -> None:
    r = runner()
    r.run(1)
    outcomes = r.switch(SWITCH, strict=True)
    assert [o.result for o in outcomes] == [UNDONE, UNDONE, "failure"]
    r.run(1)
    assert (ran(r, "/standby"), ran(r, "/teleop")) == ([0, 1], [])
    outcomes = r.switch(SWITCH, strict=False)
    assert [o.ok for o in outcomes] == [True, True, False]
    r.run(1)
    assert (ran(r, "/standby"), ran(r, "/teleop")) == ([0, 1], [2])
    r.shutdown()
