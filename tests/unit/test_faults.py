"""Faults on a SimClock: safe stops, failure policies, watchdogs. All deterministic."""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import (
    Component,
    ComponentError,
    ComponentSpec,
    FlowStatus,
    Runner,
    RunnerSettings,
    SimClock,
)
from rtcf._core._errors import ConfigurationError, LoopError
from rtcf._core._executor import ABORT
from rtcf._core._faults import FailurePolicy, downstream
from rtcf._core._log import LogRecord

P = 10_000_000  # period at 100 Hz
EVENTS: list[str] = []  # safe_stop/stop/start calls, in the order they happened


class Sink:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def __call__(self, rec: LogRecord) -> None:
        self.lines.append(f"{rec.logger}: {rec.format()}")


class Hardware(Component):
    """The hardware interface: reads a command, writes a state; safe_stop zeroes it."""

    def configure(self) -> None:
        self.cmd = self.add_input("cmd", float)
        self.state = self.add_output("state", float)
        self.torque = 1.0

    def update(self) -> None:
        self.state.write(float(self.iteration))

    def safe_stop(self) -> None:
        self.torque = 0.0
        EVENTS.append(f"safe_stop {self.name}")


class Controller(Component):
    """Reads the state, writes the command; raises at iterations listed in ~fail_at."""

    def configure(self) -> None:
        self.fail_at = set(self.params.get("~fail_at", []))
        self.exc: Any = self.params.get("~exc", "ZeroDivisionError")
        self.state = self.add_input("state", float)
        self.cmd = self.add_output("cmd", float)
        self.seen: list[int] = []

    def start(self) -> None:
        EVENTS.append(f"start {self.name}")

    def update(self) -> None:
        if self.iteration in self.fail_at:
            if self.exc == "SystemExit":
                raise SystemExit(3)
            raise ZeroDivisionError("boom")
        self.seen.append(self.iteration)
        self.cmd.write(2.0 * (self.state.read() or 0.0))

    def stop(self) -> None:
        EVENTS.append(f"stop {self.name}")

    def safe_stop(self) -> None:
        EVENTS.append(f"safe_stop {self.name}")


class Display(Component):
    """A leaf that reads the command (nothing reads it back)."""

    def configure(self) -> None:
        self.cmd = self.add_input("cmd", float)
        self.seen: list[tuple[int, FlowStatus]] = []

    def update(self) -> None:
        self.cmd.read()
        self.seen.append((self.iteration, self.cmd.status))

    def safe_stop(self) -> bool:
        EVENTS.append(f"safe_stop {self.name}")
        return False


class Logger(Component):
    """An independent leaf that fails."""

    def configure(self) -> None:
        self.fail_at = set(self.params.get("~fail_at", []))
        self.ran: list[int] = []

    def update(self) -> None:
        if self.iteration in self.fail_at:
            raise RuntimeError("disk full")
        self.ran.append(self.iteration)

    def safe_stop(self) -> None:
        raise OSError("cannot flush")


def _runner(*specs: ComponentSpec, **settings: Any) -> tuple[Runner, Sink]:
    EVENTS.clear()
    sink = Sink()
    runner = Runner(
        RunnerSettings(frequency=100.0, **settings), clock=SimClock(), log_sink=sink
    )
    for spec in specs:
        runner.load(spec)
    return runner, sink


def _leaf_logger(fail_at: int) -> ComponentSpec:
    """The logger, a leaf nothing reads, failing in iteration ``fail_at`` and deactivated."""
    return ComponentSpec(
        "logger", Logger, params={"fail_at": [fail_at]}, policy=FailurePolicy(on_error="deactivate")
    )


def _loop(ctrl_policy: FailurePolicy | None = None, fail_at: tuple[int, ...] = (), **extra: Any):
    specs = [
        ComponentSpec("hw", Hardware, is_first=True),
        ComponentSpec(
            "ctrl",
            Controller,
            params={"fail_at": list(fail_at), **extra},
            policy=ctrl_policy or FailurePolicy(),
        ),
        ComponentSpec("display", Display),
    ]
    return specs


def test_stop_policy_runs_every_safe_stop_last_first_and_names_the_failure() -> None:
    runner, sink = _runner(*_loop(fail_at=(3,)))
    with pytest.raises(ComponentError) as info:
        runner.run(10)
    assert str(info.value).startswith(
        "component '/ctrl': update() raised ZeroDivisionError: boom at iteration 3"
    )
    assert "the loop was stopped" in str(info.value)
    # order: /hw -> /ctrl -> /display, so the safe stops go display, ctrl, hw
    assert [e for e in EVENTS if e.startswith("safe_stop")] == [
        "safe_stop display",
        "safe_stop ctrl",
        "safe_stop hw",
    ]
    assert runner.components["/hw"].torque == 0.0
    outcomes = {o.component: (o.ok, o.detail) for o in runner.safe_stops}
    assert outcomes == {
        "/display": (False, "returned False"),
        "/ctrl": (True, ""),
        "/hw": (True, ""),
    }
    assert any("/display: safe_stop() returned False" in line for line in sink.lines)
    assert runner.state.iteration == 3


def test_system_exit_in_update_is_named_and_always_stops() -> None:
    policy = FailurePolicy(on_error="deactivate")
    runner, _ = _runner(*_loop(policy, fail_at=(2,), exc="SystemExit"))
    with pytest.raises(ComponentError, match=r"'/ctrl': update\(\) raised SystemExit: 3 at "
                       r"iteration 2"):
        runner.run(10)
    assert "safe_stop hw" in EVENTS


def test_deactivate_takes_out_the_component_and_its_downstream_feedback_included() -> None:
    # ctrl -> display (reads cmd) and ctrl -> hw (reads cmd, feedback: hw is first)
    runner, sink = _runner(*_loop(FailurePolicy(on_error="deactivate"), fail_at=(3,)))
    runner.load(ComponentSpec("logger", Logger))
    result = runner.run(8)
    assert result.iterations == 8 and result.stopped_by == "count"
    (fault,) = result.faults
    assert (fault.component, fault.iteration, fault.action) == ("/ctrl", 3, "deactivated")
    assert fault.error == "ZeroDivisionError: boom"
    assert sorted(fault.taken_out) == ["/ctrl", "/display", "/hw"]
    # the logger is independent of ctrl: it ran every iteration
    # the failed iteration ends at the failure: what comes after ctrl in it does not run
    assert runner.components["/logger"].ran == [0, 1, 2, 4, 5, 6, 7]
    assert runner.lifecycle_state("/hw") == "inactive"
    assert runner.lifecycle_state("/logger") == "active"
    # safe stops of those taken out only, last in the order first (logger's is not run)
    assert EVENTS[-3:] == ["safe_stop display", "safe_stop ctrl", "safe_stop hw"]
    assert any("took out of the schedule" in line for line in sink.lines)
    assert runner.faults == [fault]


def test_deactivate_keeps_the_rest_on_the_same_time_grid_deterministically() -> None:
    def once() -> tuple[list[int], list[Any]]:
        runner, _ = _runner(ComponentSpec("hw", Hardware), _leaf_logger(4))
        result = runner.run(10)
        assert [f.taken_out for f in result.faults] == [["/logger"]]
        return runner.components["/logger"].ran, [runner.state.time_ns, result.iterations]

    first = once()
    assert first == once()
    assert first[0] == [0, 1, 2, 3]
    assert first[1] == [9 * P, 10]  # iteration 10 at t = 9 periods: no gap in the grid


def test_a_leaf_failure_takes_out_only_the_leaf() -> None:
    runner, sink = _runner(*_loop(), _leaf_logger(2))
    result = runner.run(5)
    assert [f.taken_out for f in result.faults] == [["/logger"]]
    assert runner.components["/ctrl"].seen == [0, 1, 2, 3, 4]
    # the logger's safe_stop raised: reported, nothing else affected
    assert [(o.component, o.ok, o.detail) for o in result.safe_stops] == [
        ("/logger", False, "raised OSError: cannot flush")
    ]
    assert any("/logger: safe_stop() raised OSError: cannot flush" in s for s in sink.lines)


def test_restart_brings_the_component_back_at_most_max_restarts_times() -> None:
    policy = FailurePolicy(on_error="restart", max_restarts=2)
    runner, _ = _runner(*_loop(policy, fail_at=(2, 4, 6)))
    result = runner.run(9)
    assert [(f.iteration, f.action) for f in result.faults] == [
        (2, "restarted"),
        (4, "restarted"),
        (6, "deactivated"),
    ]
    ctrl = runner.components["/ctrl"]
    assert ctrl.seen == [5]  # configure again resets what it saw (3 came before 4)
    assert EVENTS.count("stop ctrl") == 2 and EVENTS.count("start ctrl") == 3
    assert runner.lifecycle_state("/ctrl") == "inactive"
    assert result.iterations == 9


def test_watchdog_consecutive_overruns_ends_through_safe_stop() -> None:
    clock_holder: dict[str, SimClock] = {}

    class Slow(Component):
        def configure(self) -> None:
            self.x = self.add_output("slow", float)

        def update(self) -> None:
            if self.iteration >= 5:
                clock_holder["clock"].advance(2 * P)  # takes two periods

        def safe_stop(self) -> None:
            EVENTS.append("safe_stop slow")

    EVENTS.clear()
    clock = SimClock()
    clock_holder["clock"] = clock
    runner = Runner(
        RunnerSettings(frequency=100.0, max_consecutive_overruns=3),
        clock=clock,
        log_sink=Sink(),
    )
    runner.load(ComponentSpec("slow", Slow))
    with pytest.raises(LoopError) as info:
        runner.run(50)
    assert str(info.value) == (
        "runner 'rt_runner': watchdog max_consecutive_overruns=3: 4 overruns in a row at "
        "iteration 8; the loop was stopped"
    )
    assert EVENTS == ["safe_stop slow"]


def test_watchdog_overruns_per_second() -> None:
    class Jittery(Component):
        clock: SimClock

        def update(self) -> None:
            if self.iteration % 10 == 0:  # one overrun every 10 iterations, never in a row
                Jittery.clock.advance(2 * P)

    clock = SimClock()
    Jittery.clock = clock
    runner = Runner(
        RunnerSettings(frequency=100.0, max_overruns_per_second=5, max_consecutive_overruns=2),
        clock=clock,
        log_sink=Sink(),
    )
    runner.load(ComponentSpec("j", Jittery))
    with pytest.raises(LoopError, match="max_overruns_per_second=5: 6 overruns within one "
                       "second at iteration 50"):
        runner.run(500)


def test_abort_stop_word_runs_safe_stops_and_says_so() -> None:
    runner, _ = _runner(*_loop())

    def abort_at_4() -> None:
        if runner.state.iteration == 4:
            runner.stop_flag.set(ABORT)

    result = runner.run(10, on_iteration=abort_at_4)
    assert result.stopped_by == "abort" and result.iterations == 5  # 0 to 4
    assert [o.component for o in result.safe_stops] == ["/display", "/ctrl", "/hw"]


def test_a_normal_stop_runs_no_safe_stop() -> None:
    runner, _ = _runner(*_loop())
    result = runner.run(5)
    assert result.stopped_by == "count" and result.safe_stops == []
    assert not any(e.startswith("safe_stop") for e in EVENTS)


def test_policy_from_params_checks_values_and_names_the_component() -> None:
    policy = FailurePolicy.from_params({"on_error": "Restart", "max_restarts": "5"}, "/c")
    assert policy == FailurePolicy("restart", 5, "")
    with pytest.raises(ConfigurationError, match="component '/c': on_error must be one of "
                       "stop, deactivate, restart, not 'explode'"):
        FailurePolicy.from_params({"on_error": "explode"}, "/c")
    with pytest.raises(ConfigurationError, match="max_restarts must be a whole number"):
        FailurePolicy.from_params({"max_restarts": -1}, "/c")


def test_downstream_follows_every_edge_once() -> None:
    edges = [("a", "b"), ("b", "c"), ("c", "a"), ("b", "d"), ("x", "y")]
    assert downstream("b", edges) == ["b", "c", "d", "a"]
    assert downstream("y", edges) == ["y"]


class Backup(Component):
    """A simpler controller: writes a constant command on the same topic."""

    def configure(self) -> None:
        self.state = self.add_input("state", float)
        self.cmd = self.add_output("cmd", float)

    def start(self) -> None:
        EVENTS.append(f"start {self.name}")

    def update(self) -> None:
        self.cmd.write(-1.0)


class CmdProbe(Component):
    """Reads the command every iteration (after both controllers in the order)."""

    def configure(self) -> None:
        self.cmd = self.add_input("cmd", float)
        self.seen: list[tuple[int, Any]] = []

    def update(self) -> None:
        self.seen.append((self.iteration, self.cmd.read()))


def test_fallback_takes_over_the_outputs_and_the_readers_go_on() -> None:
    specs = [
        ComponentSpec("hw", Hardware, is_first=True),
        ComponentSpec(
            "ctrl", Controller, params={"fail_at": [3]},
            policy=FailurePolicy(on_error="deactivate", fallback="/backup"),
        ),
        ComponentSpec("backup", Backup),
        ComponentSpec("probe", CmdProbe),
    ]
    runner, sink = _runner(*specs)
    # the fallback stands by: right after its primary in the order, not started
    assert runner.order.index("/backup") == runner.order.index("/ctrl") + 1
    result = runner.run(6)
    # the backup started only when ctrl failed; hw was not safe-stopped
    assert EVENTS == ["start ctrl", "safe_stop ctrl", "start backup"]
    (fault,) = result.faults
    assert (fault.taken_out, fault.fallback) == (["/ctrl"], "/backup")
    probe = runner.components["/probe"]
    # ctrl wrote 2 * state until iteration 2; iteration 3 failed in ctrl (the rest of it
    # did not run); from iteration 4 the backup's -1.0 arrives on the same topic
    assert probe.seen == [(0, 0.0), (1, 2.0), (2, 4.0), (4, -1.0), (5, -1.0)]
    assert runner.lifecycle_state("/hw") == "active"
    assert runner.lifecycle_state("/backup") == "active"
    assert runner.components["/hw"].torque == 1.0  # hw was not safe-stopped
    assert "took out of the schedule: /ctrl; /backup took over its outputs" in " ".join(
        sink.lines
    )


def test_a_fault_says_what_it_contained_by_its_cause_not_its_words() -> None:
    """An update that raised is told as one; a LET lane's overrun windows in the
    watchdog's own words, whatever an exception's message happens to say."""
    from rtcf._core._faults import LET_OVERRUNS, Fault

    words = "watchdog max_let_overruns=2: 3 windows not finished in time"
    raised = Fault("/c", 7, f"RuntimeError: {words}", "deactivated", ["/c"])
    overran = Fault("/c", 7, words, "deactivated", ["/c"], cause=LET_OVERRUNS)
    assert raised.describe().startswith(
        f"component '/c': update() raised RuntimeError: {words} at iteration 7; took out")
    assert overran.describe().startswith(f"component '/c': {words}; took out")
    assert Fault(**overran.to_dict()) == overran  # as the supervisor reads it back
