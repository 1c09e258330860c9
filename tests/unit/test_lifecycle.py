"""Lifecycle transitions of single components while the loop runs, on a SimClock.

A transition swaps the executor's plan between two iterations; the other components
go on, on the same time grid. Everything here is deterministic: same inputs, same
iterations, same values.
"""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import Component, ComponentSpec, FlowStatus, Runner, RunnerSettings, SimClock
from rtcf._core import _lifecycle as lc
from rtcf._core._executor import SKIPPED, Executor, StopFlag, compile_plan
from rtcf._core._log import LogRecord
from rtcf._core._loop_state import LoopState
from rtcf._core._rings import Ring
from rtcf._core._timing import FIXED_COLUMNS, TimingAggregate, TimingWriter, local_ring
from rtcf._core._tunables import (
    LIFECYCLE,
    UPDATE_RECORD_SIZE,
    UpdateReader,
    encode_update,
)

from .test_runner import Recorder

P = 10_000_000  # period at 100 Hz
EVENTS: list[str] = []


class Sink:
    def __init__(self) -> None:
        self.records: list[tuple[int, str, str, int]] = []

    def __call__(self, rec: LogRecord) -> None:
        self.records.append((rec.level, rec.logger, rec.format(), rec.iteration))


class Source(Component):
    """Writes its iteration to ``x``; records when it ran."""

    def configure(self) -> None:
        self.out = self.add_output("x", float)
        self.ran: list[tuple[int, int]] = []

    def update(self) -> None:
        self.ran.append((self.iteration, self.time_ns))
        self.out.write(float(self.iteration))


class Relay(Component):
    """``y = x + gain``; records every hook with the iteration it saw."""

    result: dict[str, Any] = {}  # hook -> what it returns, or an exception to raise
    in_type: type = float

    def configure(self) -> Any:
        self.inp = self.add_input("x", self.in_type)
        self.out = self.add_output("y", float)
        self.gain = self.params.declare("gain", 1000.0)
        return self._hook("configure")

    def start(self) -> Any:
        return self._hook("start")

    def update(self) -> None:
        EVENTS.append(f"update {self.iteration}")
        v = self.inp.read()
        if v is not None:
            self.out.write(v + self.gain.value)

    def stop(self) -> Any:
        self.log.nonrt.info("stopping")  # allowed: a hook, not update
        return self._hook("stop")

    def cleanup(self) -> Any:
        return self._hook("cleanup")

    def _hook(self, name: str) -> Any:
        EVENTS.append(f"{name} {self.iteration}")
        what = self.result.get(name)
        if isinstance(what, BaseException):
            raise what
        return what


@pytest.fixture(autouse=True)
def _reset() -> Any:
    EVENTS.clear()
    Relay.result = {}
    Relay.in_type = float
    yield


def chain(clock: SimClock | None = None) -> tuple[Runner, Source, Relay, Recorder]:
    r = Runner(RunnerSettings(frequency=100.0), clock=clock or SimClock(), log_sink=Sink())
    src = r.load(ComponentSpec("src", Source))
    relay = r.load(ComponentSpec("relay", Relay))
    sink = r.load(ComponentSpec("sink", Recorder))
    assert isinstance(src, Source) and isinstance(relay, Relay) and isinstance(sink, Recorder)
    return r, src, relay, sink


def at(runner: Runner, plan: dict[int, str], outcomes: list[lc.TransitionOutcome]) -> Any:
    """on_iteration: after iteration i, ask for transition plan[i] of /relay."""

    def hook() -> None:
        transition = plan.get(runner.state.iteration)
        if transition is not None:
            outcomes.append(runner.change_state("/relay", transition))

    return hook


# -- the state machine ---------------------------------------------------------------


def test_available_transitions_are_rcl_lifecycles() -> None:
    def names(state: int) -> list[tuple[int, str, int]]:
        return [(d.transition, d.label, d.goal) for d in lc.available_transitions(state)]

    assert names(lc.UNCONFIGURED) == [(1, "configure", 10), (5, "shutdown", 12)]
    assert names(lc.INACTIVE) == [(2, "cleanup", 11), (3, "activate", 13), (6, "shutdown", 12)]
    assert names(lc.ACTIVE) == [(4, "deactivate", 14), (7, "shutdown", 12)]
    assert names(lc.FINALIZED) == []
    assert lc.resolve_transition(lc.ACTIVE, "shutdown") == 7
    assert lc.resolve_transition(lc.INACTIVE, 3) == 3
    assert lc.resolve_transition(lc.INACTIVE, "deactivate") is None
    graph = lc.transition_graph()
    assert len(graph) == 25 and graph[0].label == "configure" and graph[-1].transition == 62


def test_outcome_steps_are_the_transition_events_of_a_managed_node() -> None:
    ok = lc.TransitionOutcome(lc.DEACTIVATE, lc.ACTIVE, lc.INACTIVE, lc.SUCCESS)
    assert [(s.transition, s.start, s.goal) for s in ok.steps()] == [(4, 3, 14), (40, 14, 2)]
    err = lc.TransitionOutcome(lc.ACTIVATE, lc.INACTIVE, lc.UNCONFIGURED, lc.ERROR, lc.SUCCESS)
    assert [(s.transition, s.label) for s in err.steps()] == [
        (3, "activate"), (32, "transition_error"), (60, "transition_success"),
    ]
    assert lc.refused(lc.ACTIVE, "no").steps() == []
    record = lc.encode_outcome(42, err, "/arm/sum1")
    assert lc.decode_outcome(record) == (42, "/arm/sum1", err)


# -- deactivate and activate while running ---------------------------------------------


def test_deactivate_takes_one_component_out_between_iterations_and_activate_brings_it_back():
    r, src, _relay, sink = chain()
    outcomes: list[lc.TransitionOutcome] = []
    r.run(12, on_iteration=at(r, {4: "deactivate", 8: "activate"}, outcomes))
    assert [o.ok for o in outcomes] == [True, True]
    assert [(o.start, o.end) for o in outcomes] == [(lc.ACTIVE, lc.INACTIVE), (lc.INACTIVE, 3)]
    # stop ran after iteration 4, start after iteration 8; no update in between
    updates = [int(e.split()[1]) for e in EVENTS if e.startswith("update")]
    assert updates == [0, 1, 2, 3, 4, 9, 10, 11]
    assert "stop 4" in EVENTS and "start 8" in EVENTS
    assert EVENTS.index("stop 4") == EVENTS.index("update 4") + 1
    # downstream: new data up to 4, the old value while the relay is out, new again from 9
    statuses = {i: st for i, st, _ in sink.seen}
    assert all(statuses[i] is FlowStatus.NEW_DATA for i in (0, 4, 9, 11))
    assert all(statuses[i] is FlowStatus.OLD_DATA for i in range(5, 9))
    assert [v for i, _, v in sink.seen if 5 <= i <= 8] == [1004.0] * 4
    # the others ran every iteration, on the grid
    assert src.ran == [(i, i * P) for i in range(12)]
    assert r.lifecycle_state("/relay") == "active"


def test_the_time_grid_goes_on_when_a_hook_takes_long() -> None:
    clock = SimClock()
    r, src, relay, _ = chain(clock)

    class Slow:
        def stop(self) -> None:  # 2.5 periods, between iterations 3 and 4
            clock.advance(5 * P // 2)

    relay.stop = Slow().stop  # type: ignore[method-assign]
    outcomes: list[lc.TransitionOutcome] = []
    r.run(8, on_iteration=at(r, {3: "deactivate"}, outcomes))
    assert outcomes[0].ok
    # absolute deadlines: the late iterations run back to back, none is skipped, and
    # every scheduled time stays where it was
    assert src.ran == [(i, i * P) for i in range(8)]


def test_a_transition_from_the_update_ring_applies_to_that_very_iteration() -> None:
    """The worker's path, in one process: the record is read at the start of an
    iteration (a feeder), the hook runs there, and that iteration runs the new plan."""
    r, src, _relay, _sink = chain()
    ring = Ring.create(bytearray(Ring.nbytes(8, UPDATE_RECORD_SIZE)), 8, UPDATE_RECORD_SIZE)
    answers: list[tuple[int, lc.TransitionOutcome]] = []

    def apply(kind: int, component: str, name: str, value: Any) -> None:
        outcome = r.apply_update(kind, component, name, value)
        assert outcome is not None
        answers.append((value, outcome))

    def send() -> None:
        if r.state.iteration == 2:
            ring.push(encode_update(LIFECYCLE, "/relay", "deactivate", 7))
        if r.state.iteration == 5:
            ring.push(encode_update(LIFECYCLE, "/relay", "3", 8))  # by id: activate

    r.run(8, on_iteration=send, feeders=(UpdateReader(ring, apply),))
    assert [(n, o.ok, o.end) for n, o in answers] == [(7, True, lc.INACTIVE), (8, True, 3)]
    # read at the start of iteration 3: stop saw iteration 3, and 3 ran without the relay
    assert "stop 3" in EVENTS and "start 6" in EVENTS
    assert [int(e.split()[1]) for e in EVENTS if e.startswith("update")] == [0, 1, 2, 6, 7]
    assert [i for i, _ in src.ran] == list(range(8))


def test_a_deactivated_component_costs_no_timing_sample() -> None:
    state = LoopState(100.0)
    calls: list[int] = []
    updates = [lambda: calls.append(0), lambda: calls.append(1), lambda: calls.append(2)]
    ring = local_ring(3, 64)
    ex = Executor(updates, SimClock(), state, TimingWriter(["/a", "/b", "/c"], ring))
    ex.idle = lambda: ex.set_active([True, state.iteration < 1, True])
    ex.run(4, StopFlag())
    assert calls == [0, 1, 2, 0, 1, 2, 0, 2, 0, 2]
    assert ex.plan == compile_plan(updates, [True, False, True])
    rows = ring.data.cast("q")
    width = ring.record_size // 8
    assert [rows[i * width + FIXED_COLUMNS + 1] for i in range(4)] == [0, 0, SKIPPED, SKIPPED]
    aggregate = TimingAggregate()
    aggregate.consume(ring, ["/a", "/b", "/c"])
    assert [len(aggregate.components[n]) for n in ("/a", "/b", "/c")] == [4, 2, 4]
    rows.release()


# -- results: failure, error, error processing ---------------------------------------------


def test_a_hook_returning_false_leaves_the_component_where_it_was() -> None:
    r, _, _relay, _ = chain()
    r.run(2)
    Relay.result = {"stop": False}
    out = r.change_state("relay", "deactivate")
    assert (out.ok, out.result, out.end_label) == (False, "failure", "active")
    assert "stop() returned False" in out.reason
    r.run(2)  # still in the schedule
    assert [e for e in EVENTS if e.startswith("update")][-2:] == ["update 2", "update 3"]
    Relay.result = {}
    assert r.change_state("relay", "deactivate").ok
    Relay.result = {"start": False}
    out = r.change_state("relay", "activate")
    assert (out.ok, out.end_label) == (False, "inactive")
    EVENTS.clear()
    r.run(2)
    assert not [e for e in EVENTS if e.startswith("update")]


def test_a_hook_that_raises_goes_through_error_processing() -> None:
    r, _, _relay, _ = chain()
    r.run(1)
    assert r.change_state("relay", "deactivate").ok
    Relay.result = {"start": RuntimeError("motor not ready")}
    EVENTS.clear()
    out = r.change_state("relay", "activate")
    # error processing ran cleanup, which succeeded: unconfigured, may be configured again
    assert (out.ok, out.result, out.error_result, out.end_label) == (
        False, "error", "success", "unconfigured"
    )
    assert "start() raised RuntimeError: motor not ready" in out.reason
    assert EVENTS == ["start 0", "cleanup 0"]
    assert [s.transition for s in out.steps()] == [3, 32, 60]
    Relay.result = {}
    assert r.change_state("relay", "configure").ok
    assert r.change_state("relay", "activate").ok
    # a cleanup that raises cannot be trusted to have released anything: finalized
    assert r.change_state("relay", "deactivate").ok
    Relay.result = {"cleanup": OSError("bus error")}
    out = r.change_state("relay", "cleanup")
    assert (out.result, out.error_result, out.end_label) == ("error", "failure", "finalized")
    assert [s.transition for s in out.steps()] == [2, 22, 61]
    assert not r.change_state("relay", "configure").ok  # nothing leaves finalized


def test_shutdown_runs_what_the_state_needs_and_finalizes() -> None:
    r, _, _relay, _ = chain()
    r.run(1)
    EVENTS.clear()
    out = r.change_state("/relay", "shutdown")
    assert (out.ok, out.transition, out.end_label) == (True, lc.ACTIVE_SHUTDOWN, "finalized")
    assert EVENTS == ["stop 0", "cleanup 0"]
    r.run(2)
    assert not [e for e in EVENTS if e.startswith("update")]
    r.unload("/relay")  # no hook runs again
    assert EVENTS == ["stop 0", "cleanup 0"]


def test_unknown_unavailable_and_unloaded_are_refused_and_nothing_runs() -> None:
    r, _, _relay, _ = chain()
    r.run(1)
    EVENTS.clear()
    for name, transition, words in [
        ("relay", "activate", "is active: no transition 'activate'"),
        ("relay", "explode", "available: deactivate [4], shutdown [7]"),
        ("relay", 1, "no transition 1"),
        ("ghost", "deactivate", "'/ghost' is not loaded"),
    ]:
        out = r.change_state(name, transition)
        assert (out.ok, out.result, out.steps()) == (False, "refused", [])
        assert words in out.reason
    assert EVENTS == []


def test_transitions_are_logged_under_the_components_name() -> None:
    r, _, _, _ = chain()
    r.run(1)
    r.change_state("relay", "deactivate")
    r.change_state("relay", "deactivate")
    sink = r.log_sink
    assert isinstance(sink, Sink)
    lines = [(lvl, who, text) for lvl, who, text, _ in sink.records if "lifecycle" in text]
    assert lines[0] == (20, "/relay", "lifecycle: deactivate: active -> inactive")
    assert lines[1][0] == 40 and "no transition 'deactivate'" in lines[1][2]
    assert (20, "/relay", "stopping", 0) in sink.records  # nonrt logging in the hook


# -- configure again -------------------------------------------------------------------------


def test_cleanup_and_configure_again_keep_the_ports_and_tunable_values() -> None:
    r, _, relay, sink = chain()
    r.run(3)
    ports = (relay.inp, relay.out)
    r.set_parameter("relay", "gain", 5.0)
    for t in ("deactivate", "cleanup", "configure", "activate"):
        assert r.change_state("relay", t).ok, t
    assert (relay.inp, relay.out) == ports  # the same objects: wiring and mapping stand
    assert relay.gain.value == 5.0  # as a ROS 2 node keeps its parameters
    r.run(2)
    assert sink.seen[-1] == (4, FlowStatus.NEW_DATA, 9.0)
    assert EVENTS.count("configure 2") == 1 and EVENTS.count("cleanup 2") == 1


def test_configure_again_with_other_ports_is_an_error_and_cleans_up() -> None:
    r, _, relay, _ = chain()
    r.run(1)
    assert r.change_state("relay", "deactivate").ok
    assert r.change_state("relay", "cleanup").ok
    Relay.in_type = int
    EVENTS.clear()
    out = r.change_state("relay", "configure")
    assert (out.result, out.error_result, out.end_label) == ("error", "success", "unconfigured")
    assert "input port 'x' (int)" in out.reason and "same ports" in out.reason
    assert EVENTS == ["cleanup 0"]  # configure raised at add_input; error processing cleaned
    assert relay.inp.type is float  # the runner's view of the ports is unchanged
    Relay.in_type = float
    assert r.change_state("relay", "configure").ok


def test_configure_again_without_a_port_or_tunable_is_an_error() -> None:
    class Forgetful(Component):
        first = True

        def configure(self) -> None:
            if Forgetful.first:
                self.add_output("a", float)
                self.params.declare("k", 1)
            Forgetful.first = False

    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock(), log_sink=Sink())
    r.load(ComponentSpec("f", Forgetful))
    assert r.change_state("f", "cleanup").ok
    out = r.change_state("f", "configure")
    assert out.result == "error" and out.end_label == "unconfigured"
    assert "did not declare port 'a', tunable parameter 'k' again" in out.reason


def test_an_explicitly_deactivated_component_stays_so_when_the_loop_restarts() -> None:
    r, _, _relay, _ = chain()
    r.run(1)
    assert r.change_state("relay", "deactivate").ok
    r.load(ComponentSpec("late", Source, remaps={"x": "x2"}))  # re-resolves, restarts
    EVENTS.clear()
    r.run(2)
    assert r.lifecycle_state("late") == "active"
    assert r.lifecycle_state("relay") == "inactive"
    assert not [e for e in EVENTS if e.startswith(("update", "start"))]
    assert r.describe_component("relay")["lifecycle"] == "inactive"


def test_listeners_hear_transitions_and_what_a_fault_policy_takes_out() -> None:
    from rtcf._core._faults import FailurePolicy

    class Breaks(Source):
        def update(self) -> None:
            if self.iteration == 3:
                raise RuntimeError("sensor lost")
            super().update()

    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock(), log_sink=Sink())
    r.load(ComponentSpec("src", Breaks, policy=FailurePolicy(on_error="deactivate")))
    r.load(ComponentSpec("relay", Relay))
    r.load(ComponentSpec("sink", Recorder))
    heard: list[tuple[str, str, str]] = []
    r.transition_listeners.append(lambda n, o: heard.append((n, o.label, o.end_label)))
    r.run(6)
    # the runner's activation at the start, in execution order; then the failed component and what
    # reads it, directly or not, as deactivations
    assert heard == [(n, "activate", "active") for n in ("/src", "/relay", "/sink")] + [
        ("/src", "deactivate", "inactive"), ("/relay", "deactivate", "inactive"),
        ("/sink", "deactivate", "inactive"),
    ]
    assert r.change_state("relay", "activate").ok
    r.change_state("relay", "activate")  # refused: not heard
    assert heard[-1] == ("/relay", "activate", "active") and len(heard) == 7
