"""Input deadlines (rtcf._core._deadlines) on the simulated clock: the exact iteration
they apply in, each on_deadline policy, the recovery, and what a run reports.

The unit suite runs on the compiled path and again with RTCF_PURE_PYTHON=1: these
tests hold on both (test_hotpath.py checks the ports' EXPIRED side by side).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from rtcf import Component, ComponentError, ComponentSpec
from rtcf._core import _deadlines, _interpreted
from rtcf._core._clock import SimClock
from rtcf._core._errors import ConfigurationError
from rtcf._core._faults import FailurePolicy
from rtcf._core._ports import FlowStatus
from rtcf._core._runner import Runner
from rtcf._core._settings import RunnerSettings
from rtcf._core._timing import TimingAggregate
from rtcf._runtime._health import health
from rtcf._runtime._live_status import LiveStatus
from rtcf.testing import SILENCE, run_components, run_launch

HZ = 100.0  # 10 ms per iteration


class Ctrl(Component):
    """Passes /cmd on to /u; notes each iteration's status and its activations."""

    deadline: float | None = 0.025

    def configure(self) -> None:
        self.cmd = self.add_input("cmd", float, deadline=self.deadline)
        self.u = self.add_output("u", float)
        self.statuses: list[tuple[int, FlowStatus]] = []
        self.activations: list[int] = []
        self.safe_stops = 0

    def start(self) -> None:
        self.activations.append(self.iteration)

    def update(self) -> None:
        self.statuses.append((self.iteration, self.cmd.status))
        value = self.cmd.read()
        self.u.write(0.0 if value is None else value)

    def safe_stop(self) -> None:
        self.safe_stops += 1


class NoDeadline(Ctrl):
    deadline = None


class Hold(Component):
    def configure(self) -> None:
        self.u = self.add_output("u", float)

    def update(self) -> None:
        self.u.write(-1.0)


def _run(policy: str, feed: list[Any], *, cls: type[Ctrl] = Ctrl, **deadlines: float) -> Any:
    specs = [
        ComponentSpec("ctrl", cls, policy=FailurePolicy(
            on_deadline=policy, fallback="/hold", deadlines=tuple(deadlines.items()),
        )),
        ComponentSpec("hold", Hold),
    ]
    return run_components(specs, len(feed), frequency=HZ, inputs={"/cmd": feed})


# the last value arrives at iteration 2 (t=20 ms); a deadline of 25 ms passes after
# t=45 ms: iteration 5 (t=50 ms) is the first past it. Values again from iteration 9.
FEED = [1.0] * 3 + [SILENCE] * 6 + [2.0] * 3


@pytest.mark.parametrize(
    ("deadline", "first"),
    # exactly last arrival + deadline is not later: the next iteration is
    [(0.025, 5), (0.03, 6), (0.0300001, 6), (0.0299999, 5), (0.001, 3), (0.06, None)],
)
def test_the_deadline_applies_in_the_first_iteration_that_starts_later(
    deadline: float, first: int | None
) -> None:
    trace = _run("continue", FEED, cmd=deadline)
    statuses = trace.components["/ctrl"].statuses
    expired = [i for i, s in statuses if s is FlowStatus.EXPIRED]
    if first is None:
        assert expired == [] and trace.result.deadline_events == []
        return
    assert expired == list(range(first, 9))
    (event,) = trace.result.deadline_events
    assert (event.iteration, event.back_iteration) == (first, 9)
    assert (event.time, event.last_arrival, event.back_time) == (first / HZ, 0.02, 0.09)


def test_continue_lets_the_component_decide_and_a_new_value_clears_it() -> None:
    trace = _run("continue", FEED)
    ctrl = trace.components["/ctrl"]
    assert trace.outputs["/u"] == [1.0] * 9 + [2.0] * 3  # it kept its last value
    assert dict(ctrl.statuses)[9] is FlowStatus.NEW_DATA
    assert ctrl.activations == [-1] and ctrl.safe_stops == 0
    summary = trace.result.deadlines["/ctrl.cmd"]
    assert summary == {
        "topic": "/cmd", "deadline": 0.025, "expired": 1, "expired_seconds": 0.04,
        "past_deadline_now": False,
    }


def test_deactivate_hands_over_to_the_fallback_and_activate_brings_it_back() -> None:
    trace = _run("deactivate", FEED)
    ctrl = trace.components["/ctrl"]
    assert trace.outputs["/u"] == [1.0] * 5 + [-1.0] * 4 + [2.0] * 3
    assert trace.ran["/ctrl"] == [0, 1, 2, 3, 4, 9, 10, 11]
    assert trace.ran["/hold"] == [5, 6, 7, 8]
    assert ctrl.activations == [-1, 9] and ctrl.safe_stops == 1  # back in iteration 9
    assert dict(ctrl.statuses)[9] is FlowStatus.NEW_DATA
    (event,) = trace.result.deadline_events
    assert (event.action, event.fallback, event.iteration, event.back_iteration) == (
        "deactivated", "/hold", 5, 9
    )
    assert trace.result.faults == []  # a silent publisher is no component failure


def test_each_silence_counts_and_the_times_add_up() -> None:
    feed = [1.0] * 2 + [SILENCE] * 5 + [1.0] + [SILENCE] * 7
    trace = _run("deactivate", feed, cmd=0.02)
    events = trace.result.deadline_events
    # arrivals at 10 ms and 70 ms: past 30 ms from iteration 4, past 90 ms from 10
    assert [(e.iteration, e.back_iteration) for e in events] == [(4, 7), (10, -1)]
    summary = trace.result.deadlines["/ctrl.cmd"]
    assert summary["expired"] == 2 and summary["past_deadline_now"]
    # 30 ms, then 100..140 ms counted to the last iteration's start
    assert summary["expired_seconds"] == pytest.approx(0.03 + 0.04)
    assert trace.ran["/hold"] == [4, 5, 6, 10, 11, 12, 13, 14]


def test_stop_ends_the_loop_through_the_safe_stops_naming_the_input() -> None:
    with pytest.raises(ComponentError, match=(
        r"component '/ctrl': input '/ctrl.cmd' \(/cmd\) past its deadline of 0.025 s at "
        r"iteration 5 .*on_deadline stop; the loop was stopped"
    )):
        _run("stop", FEED)


def test_nothing_is_watched_before_the_first_value() -> None:
    trace = _run("stop", [SILENCE] * 8 + [1.0])
    statuses = trace.components["/ctrl"].statuses
    assert [s for _, s in statuses] == [FlowStatus.NO_DATA] * 8 + [FlowStatus.NEW_DATA]


def test_the_launch_files_deadline_replaces_or_gives_the_components() -> None:
    trace = _run("continue", FEED, cls=NoDeadline, cmd=0.03)
    (event,) = trace.result.deadline_events
    assert event.iteration == 6 and event.deadline == 0.03
    assert trace.components["/ctrl"].cmd.deadline == 0.03
    with pytest.raises(ComponentError, match=r"deadline/nope names no input; its inputs: cmd"):
        _run("continue", FEED, nope=0.1)


def test_an_input_without_a_deadline_costs_no_feeder() -> None:
    trace = _run("continue", FEED, cls=NoDeadline)
    assert trace.result.deadlines == {} and trace.result.deadline_events == []
    assert {s for _, s in trace.components["/ctrl"].statuses} <= {
        FlowStatus.NEW_DATA, FlowStatus.OLD_DATA
    }


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"on_deadline": "ignore"}, "on_deadline must be one of continue, deactivate, stop"),
        ({"deadline": {"cmd": -1}}, "deadline/cmd is -1; it must be a positive number"),
        ({"deadline/cmd": "soon"}, "deadline/cmd is 'soon'"),
        ({"deadline": 0.5}, "deadline is 0.5; name the input: deadline/NAME"),
    ],
)
def test_bad_launcher_parameters_name_the_component(params: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigurationError, match=f"component '/c': {message}"):
        FailurePolicy.from_params(params, "/c")


def test_launcher_parameters_as_a_tree_or_flat() -> None:
    tree = FailurePolicy.from_params(
        {"deadline": {"cmd": "0.5", "b": 1}, "on_deadline": "Deactivate"}, "/c"
    )
    flat = FailurePolicy.from_params({"deadline.cmd": 0.5, "deadline/b": 1.0}, "/c")
    assert tree.deadlines == flat.deadlines == (("b", 1.0), ("cmd", 0.5))
    assert tree.on_deadline == "deactivate" and flat.on_deadline == "continue"


def test_add_input_rejects_a_deadline_that_is_no_time() -> None:
    class Bad(Component):
        def configure(self) -> None:
            self.add_input("cmd", float, deadline=0)

    with pytest.raises(ComponentError, match=r"input 'cmd': deadline 0 must be a positive"):
        run_components([Bad], 1)


def test_a_launch_file_gives_the_deadline_and_the_policy(tmp_path: Any) -> None:
    launch = tmp_path / "d.launch"
    here = "tests.unit.test_deadlines"
    launch.write_text(
        '<launch><node name="rt_runner" pkg="rtcf" type="rt_runner">'
        '<param name="frequency" value="100"/></node>'
        f'<node name="ctrl" pkg="rtcf" type="rt_launcher" args="{here} NoDeadline">'
        '<param name="deadline/cmd" value="0.025"/><param name="on_deadline" value="deactivate"/>'
        '<param name="fallback" value="hold"/></node>'
        f'<node name="hold" pkg="rtcf" type="rt_launcher" args="{here} Hold"/>'
        "</launch>"
    )
    trace = run_launch(str(launch), len(FEED), inputs={"/cmd": FEED})
    assert trace.outputs["/u"] == [1.0] * 5 + [-1.0] * 4 + [2.0] * 3


def test_the_watch_tells_a_supervisor_which_input_is_past_its_deadline_now() -> None:
    runner = Runner(RunnerSettings(frequency=HZ), clock=SimClock(), name="r")
    runner.load(ComponentSpec("ctrl", Ctrl))
    fed = [3]  # values in the first 3 iterations only

    def feed() -> None:
        if runner.state.iteration < fed[0]:
            slot = runner.components["/ctrl"].inputs["cmd"]._slot
            slot.value, slot.seq = 1.0, slot.seq + 1

    try:
        watch = runner.deadlines
        assert watch.names() == ["/ctrl.cmd"]
        runner.run(6, feeders=[feed])  # past 25 ms from iteration 5
        assert (watch.bits[0], watch.misses[0], watch.expired_now()) == (1, 1, ["/ctrl.cmd"])
        fed[0] = 100
        runner.run(1, feeders=[feed])
        assert (watch.bits[0], watch.misses[0], watch.expired_now()) == (0, 1, [])
    finally:
        runner.shutdown()


def test_diagnostics_name_the_inputs_past_their_deadline_and_warn() -> None:
    status = LiveStatus(
        iterations=10, overruns=0, jitter_p999_us=1.0, calc_p999_us=1.0, calc_max_us=1.0,
        log_records_dropped=0, elapsed_s=0.1, past_deadline=("/base.cmd_vel",),
        deadline_misses=3,
    )
    h = health("/rt_runner", status, TimingAggregate())
    assert h.warn and "past deadline: /base.cmd_vel" in h.message
    values = dict(h.values)
    assert values["inputs past their deadline"] == "/base.cmd_vel"
    assert values["input deadlines passed"] == "3"
    quiet = health("/rt_runner", dataclasses.replace(status, past_deadline=()), TimingAggregate())
    assert not quiet.warn and dict(quiet.values)["inputs past their deadline"] == "none"


class Two(Component):
    """Two inputs with deadlines: a deadline that passes while the other one has taken
    the component out is decided when it is back (the gate keeps asking till then)."""

    def configure(self) -> None:
        self.cmd = self.add_input("cmd", float, deadline=0.025)
        self.aux = self.add_input("aux", float, deadline=0.04)
        self.u = self.add_output("u", float)
        self.statuses: list[tuple[int, FlowStatus, FlowStatus]] = []

    def update(self) -> None:
        self.statuses.append((self.iteration, self.cmd.status, self.aux.status))
        self.u.write((self.cmd.read() or 0.0) + (self.aux.read() or 0.0))


class _EveryIteration:
    """What the watch was before its gate: the full check in every iteration (keeping
    the last look's iteration and time, as a gate does)."""

    def __init__(self, state: Any, ports: Any, seq: Any, due: Any, fn: Any) -> None:
        self.state, self.fn = state, fn
        self.last_iteration, self.last_time_ns = _interpreted.NO_LOOK, 0

    def __call__(self) -> None:
        self.fn()
        self.last_iteration, self.last_time_ns = self.state.iteration, self.state.time_ns

    def release(self) -> None:
        pass


_CHECK = _deadlines.DeadlineWatch.check
GATES = [
    pytest.param(_deadlines.DeadlineGate, id="the-loops-gate"),
    pytest.param(_interpreted.DeadlineGate, id="python-twin"),
]


def _traced(monkeypatch: pytest.MonkeyPatch, gate: Any) -> tuple[Any, list[int]]:
    """A run of Two (deactivate, /hold its fallback) with the given gate; and the
    iterations in which the watch's full check ran."""
    checks: list[int] = []

    def counted(watch: _deadlines.DeadlineWatch) -> None:
        checks.append(watch.state.iteration)
        _CHECK(watch)

    monkeypatch.setattr(_deadlines, "DeadlineGate", gate)
    monkeypatch.setattr(_deadlines.DeadlineWatch, "check", counted)
    S = SILENCE
    cmd = [1.0] * 3 + [S] * 6 + [2.0] * 8 + [S] * 6 + [3.0] * 2
    aux = [1.0] * 2 + [S] * 10 + [1.0] * 2 + [S] * 11
    specs = [
        ComponentSpec("two", Two, policy=FailurePolicy(on_deadline="deactivate",
                                                       fallback="/hold")),
        ComponentSpec("hold", Hold),
    ]
    trace = run_components(specs, len(cmd), frequency=HZ, inputs={"/cmd": cmd, "/aux": aux})
    return trace, checks


@pytest.mark.parametrize("gate", GATES)
def test_the_gate_decides_as_the_full_check_in_every_iteration_and_calls_it_rarely(
    monkeypatch: pytest.MonkeyPatch, gate: Any
) -> None:
    reference, every = _traced(monkeypatch, _EveryIteration)
    trace, checks = _traced(monkeypatch, gate)
    assert every == list(range(25))
    # iteration by iteration: the same statuses, outputs, schedule, events and totals
    assert trace.components["/two"].statuses == reference.components["/two"].statuses
    assert trace.outputs == reference.outputs and trace.ran == reference.ran
    assert trace.result.deadline_events == reference.result.deadline_events
    assert trace.result.deadlines == reference.result.deadlines
    events = [(e.port, e.iteration, e.back_iteration) for e in trace.result.deadline_events]
    # /cmd (last at 20 ms) passes 25 ms at 5: out. /aux (last at 10 ms) passes 40 ms at
    # 6, but its component is out: decided at 9, as /cmd brings it back. /cmd passes
    # its due time again at 19 while /aux has it out: no second time
    assert events == [("/two.cmd", 5, 9), ("/two.aux", 9, 12), ("/two.aux", 18, -1)]
    assert trace.ran["/hold"] == [5, 6, 7, 8, 9, 10, 11, 18, 19, 20, 21, 22, 23, 24]
    # the full check only where something changed, and while an input past its due time
    # waits for its component to be back (6-8, 19-22)
    assert checks == [5, 6, 7, 8, 9, 12, 18, 19, 20, 21, 22]


# -- values written inside the loop: they arrive in the iteration that wrote them ------


class Pausing(Component):
    """Writes /cmd (its iteration) in every iteration but those of ``silent``."""

    silent = range(20, 40)  # last value at 19, back at 40

    def configure(self) -> None:
        self.cmd = self.add_output("cmd", float)

    def update(self) -> None:
        if self.iteration not in self.silent:
            self.cmd.write(float(self.iteration))


class Slow(Ctrl):
    deadline = 0.05  # 5 iterations at 100 Hz


def _in_loop(policy: str, *, reader_first: bool = False, iterations: int = 50) -> Any:
    specs = [
        ComponentSpec("writer", Pausing),
        ComponentSpec("ctrl", Slow, is_first=reader_first, policy=FailurePolicy(
            on_deadline=policy, fallback="/hold")),
        ComponentSpec("hold", Hold),
    ]
    return run_components(specs, iterations, frequency=HZ)


def test_a_value_written_earlier_in_the_iteration_arrives_in_it() -> None:
    # last written at 19 (t=0.19 s): past 0.24 s from iteration 25, not 26; the value
    # written at 40 is NEW_DATA at 40, not EXPIRED for one more iteration
    trace = _in_loop("continue")
    statuses = dict(trace.components["/ctrl"].statuses)
    expired = [i for i, s in statuses.items() if s is FlowStatus.EXPIRED]
    assert expired == list(range(25, 40))
    assert statuses[24] is FlowStatus.OLD_DATA and statuses[40] is FlowStatus.NEW_DATA
    assert trace.outputs["/u"][40] == 40.0
    (event,) = trace.result.deadline_events
    assert (event.iteration, event.back_iteration) == (25, 40)
    assert (event.time, event.last_arrival, event.back_time) == (0.25, 0.19, 0.40)
    assert trace.result.deadlines["/ctrl.cmd"]["expired_seconds"] == pytest.approx(0.15)


def test_a_reader_before_its_writer_counts_from_the_writers_iteration() -> None:
    # is_first: the reader sees at i what was written at i - 1; the value of 19 (seen
    # at 20) is still the last one at 24 and too old at 25; the one of 40, seen at 41
    trace = _in_loop("continue", reader_first=True)
    statuses = dict(trace.components["/ctrl"].statuses)
    expired = [i for i, s in statuses.items() if s is FlowStatus.EXPIRED]
    assert expired == list(range(25, 41))
    assert statuses[41] is FlowStatus.NEW_DATA
    (event,) = trace.result.deadline_events
    assert (event.iteration, event.back_iteration, event.last_arrival) == (25, 40, 0.19)


def test_deactivate_on_a_value_written_in_the_loop_comes_back_at_the_next_boundary() -> None:
    trace = _in_loop("deactivate")
    assert trace.ran["/hold"] == list(range(25, 41))  # out at 25; back once 40 wrote
    assert trace.ran["/ctrl"] == list(range(25)) + list(range(41, 50))
    assert trace.outputs["/u"][24:26] == [19.0, -1.0] and trace.outputs["/u"][41] == 41.0
    (event,) = trace.result.deadline_events
    assert (event.action, event.iteration, event.back_iteration) == ("deactivated", 25, 40)


def test_in_loop_arrivals_carry_over_a_stop_and_a_new_run() -> None:
    # the last look's iteration and time survive the watch's refresh between two runs
    runner = Runner(RunnerSettings(frequency=HZ), clock=SimClock())
    runner.load(ComponentSpec("writer", Pausing))
    runner.load(ComponentSpec("ctrl", Slow))
    first = runner.run(20)  # ends after the last write, at 19
    second = runner.run(30)
    runner.shutdown()
    assert first.deadline_events == []
    (event,) = second.deadline_events
    assert (event.iteration, event.back_iteration, event.last_arrival) == (25, 40, 0.19)


class LetPausing(Pausing):
    silent = range(16, 10_000)  # releases 0, 5, 10, 15 write; 15's is seen from 20


def test_a_let_lanes_output_arrives_in_the_iteration_it_is_handed_over_in() -> None:
    # release 15's value becomes visible at 20 (its window's end): past 0.25 s from 26
    # (was 27: the handover, after the iteration's feeders, counted from the next look)
    from rtcf._core._rates import Rate

    trace = run_components([
        ComponentSpec("writer", LetPausing, lane="slow", rate=Rate(every=5, phase=0)),
        ComponentSpec("ctrl", Slow),
    ], 40, frequency=HZ)
    (event,) = trace.result.deadline_events
    assert (event.iteration, event.last_arrival) == (26, 0.20)
    statuses = dict(trace.components["/ctrl"].statuses)
    assert statuses[20] is FlowStatus.NEW_DATA and statuses[26] is FlowStatus.EXPIRED
