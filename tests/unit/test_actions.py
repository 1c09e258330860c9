"""Action servers in the loop: requests, decisions, the goal state table, rtcf.testing."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import pytest

import rtcf
from rtcf import ActionEvent, ActionRequest, GoalStatus
from rtcf.testing import Cancel, Goal, run_components

S = GoalStatus


class Fibonacci:
    """A plain-Python action type: any class with Goal, Result and Feedback is one."""

    @dataclass
    class Goal:
        order: int = 0

    @dataclass
    class Result:
        sequence: list[int] = field(default_factory=list)

    @dataclass
    class Feedback:
        sequence: list[int] = field(default_factory=list)


class FibServer(rtcf.Component):
    """Rejects negative orders; one term per iteration; a newer goal preempts; a cancel
    is accepted and ends the goal CANCELED in the next iteration."""

    def configure(self) -> None:
        self.fib = self.add_action_server("~/fibonacci", Fibonacci, max_goals=2)
        self.seq: dict[int, list[int]] = {}
        self.order: dict[int, int] = {}
        self.cancelling: list[int] = []

    def update(self) -> None:
        for goal_id in self.cancelling:
            self.fib.canceled(goal_id, Fibonacci.Result(self.seq.pop(goal_id)))
        self.cancelling = []
        req = self.fib.request()
        if req is not None:
            if req.kind == ActionRequest.CANCEL:
                self.fib.accept_cancel(req)
                self.cancelling.append(req.goal_id)
            elif req.goal.order < 0:
                self.fib.reject(req)
            else:
                self.fib.accept(req, preempt=Fibonacci.Result([-1]))
                self.seq = {req.goal_id: [0, 1]}
                self.order = {req.goal_id: req.goal.order}
        for goal_id in self.fib.active:
            if goal_id in self.cancelling:
                continue
            seq = self.seq[goal_id]
            if len(seq) > self.order[goal_id]:
                self.fib.succeed(goal_id, Fibonacci.Result(list(seq)))
                continue
            seq.append(seq[-1] + seq[-2])
            self.fib.publish_feedback(goal_id, Fibonacci.Feedback(list(seq)))


NAME = "/FibServer/fibonacci"


def _run(requests: dict[int, Any], iterations: int = 12) -> rtcf.testing.Trace:
    return run_components([FibServer], iterations, actions={NAME: requests})


def test_accepted_goal_runs_with_feedback_and_succeeds() -> None:
    goal = _run({1: Goal(Fibonacci.Goal(order=4), id=7)}).actions[NAME].goals[7]
    assert goal.accepted is True
    assert goal.states == [(1, S.ACCEPTED), (1, S.EXECUTING), (4, S.SUCCEEDED)]
    assert [(i, fb.sequence) for i, fb in goal.feedback] == [
        (1, [0, 1, 1]),
        (2, [0, 1, 1, 2]),
        (3, [0, 1, 1, 2, 3]),
    ]
    assert goal.status == S.SUCCEEDED
    assert goal.result == Fibonacci.Result([0, 1, 1, 2, 3])
    assert goal.goal == Fibonacci.Goal(order=4)


def test_rejected_goal_never_runs() -> None:
    goal = _run({0: Goal(Fibonacci.Goal(order=-1), id=1)}).actions[NAME].goals[1]
    assert goal.accepted is False
    assert goal.states == [] and goal.feedback == [] and goal.status == S.UNKNOWN


def test_cancel_goes_through_canceling_to_canceled() -> None:
    trace = _run({0: Goal(Fibonacci.Goal(order=50), id=1), 3: Cancel(1)})
    goal = trace.actions[NAME].goals[1]
    assert goal.cancel_accepted is True
    assert goal.states == [(0, S.ACCEPTED), (0, S.EXECUTING), (3, S.CANCELING), (4, S.CANCELED)]
    assert goal.result == Fibonacci.Result([0, 1, 1, 2, 3])  # no term once canceling
    assert trace.components["/FibServer"].fib.active == ()


def test_newer_goal_preempts_the_old_one() -> None:
    trace = _run({0: Goal(Fibonacci.Goal(order=50), id=1), 2: Goal(Fibonacci.Goal(2), id=2)})
    goals = trace.actions[NAME].goals
    assert goals[1].states[-1] == (2, S.ABORTED) and goals[1].result == Fibonacci.Result([-1])
    assert goals[2].states == [(2, S.ACCEPTED), (2, S.EXECUTING), (3, S.SUCCEEDED)]


def test_events_order_accept_before_the_preempted_result() -> None:
    seen: list[tuple[int, int]] = []

    class Spy:  # between the server and its events port: every event, in order
        def __init__(self, port: Any) -> None:
            self.port = port

        def write(self, event: ActionEvent) -> None:
            seen.append((event.kind, event.goal_id))
            self.port.write(event)

    class Recorder(FibServer):
        def configure(self) -> None:
            super().configure()
            self.fib._events = Spy(self.fib._events)  # type: ignore[assignment]

    run_components(
        [rtcf.ComponentSpec("FibServer", Recorder)], 4,
        actions={NAME: {0: Goal(Fibonacci.Goal(50), id=1), 2: Goal(Fibonacci.Goal(50), id=2)}},
    )
    at_two = seen[seen.index((ActionEvent.RESPONSE, 2)) :][:2]
    assert at_two == [(ActionEvent.RESPONSE, 2), (ActionEvent.RESULT, 1)]


def test_cancel_of_an_ended_goal_is_refused_without_the_component() -> None:
    trace = _run({0: Goal(Fibonacci.Goal(order=1), id=1), 5: Cancel(1)})
    goal = trace.actions[NAME].goals[1]
    assert goal.status == S.SUCCEEDED and goal.cancel_accepted is False


def test_requests_of_one_iteration_reach_the_component_one_per_iteration() -> None:
    trace = _run({0: [Goal(Fibonacci.Goal(-1), id=1), Goal(Fibonacci.Goal(-2), id=2)]})
    goals = trace.actions[NAME].goals
    assert goals[1].accepted is False and goals[2].accepted is False
    # answered in iterations 0 and 1: the second waited for the first to be taken
    assert trace.components["/FibServer"].fib.active == ()


def test_stop_aborts_open_goals() -> None:
    trace = _run({0: Goal(Fibonacci.Goal(order=1000), id=1)}, iterations=5)
    goal = trace.actions[NAME].goals[1]
    assert goal.states[-1] == (4, S.ABORTED) and goal.status == S.ABORTED


def test_runs_are_equal() -> None:
    def run() -> Any:
        trace = _run({0: Goal(Fibonacci.Goal(9), id=1), 3: Goal(Fibonacci.Goal(3), id=2),
                      5: Cancel(2)})
        return {k: (g.states, g.feedback, g.result) for k, g in trace.actions[NAME].goals.items()}

    assert run() == run()


class Misbehaving(rtcf.Component):
    """Does what its parameter ``act`` says with the first request."""

    def configure(self) -> None:
        self.fib = self.add_action_server("fib", Fibonacci)
        self.act = self.params.get("~act", "")
        self.kept: ActionRequest | None = None

    def update(self) -> None:
        act = self.act
        if act == "late" and self.kept is not None:
            self.fib.accept(self.kept)
        req = self.fib.request()
        if req is None:
            return
        if act == "twice":
            self.fib.accept(req)
            self.fib.accept(req)
        elif act == "cancel_decided_as_goal" and req.kind == ActionRequest.CANCEL:
            self.fib.accept(req)
        elif act == "canceled_while_executing":
            self.fib.accept(req)
            self.fib.canceled(req.goal_id)
        elif act == "succeed_twice":
            self.fib.accept(req)
            self.fib.succeed(req.goal_id)
            self.fib.succeed(req.goal_id)
        elif act == "full":
            self.fib.accept(req)
        elif act == "late":
            self.kept = req
        elif act == "feedback_after_end":
            self.fib.accept(req)
            self.fib.abort(req.goal_id)
            self.fib.publish_feedback(req.goal_id, Fibonacci.Feedback())
        elif act == "undecided":
            pass
        elif req.kind == ActionRequest.GOAL:
            self.fib.accept(req)


@pytest.mark.parametrize(
    ("act", "words"),
    [
        ("twice", "decided already"),
        ("cancel_decided_as_goal", "accept_cancel/reject_cancel"),
        ("canceled_while_executing", "forbids EXECUTING -> CANCELED"),
        ("succeed_twice", "goal 1 is not open"),
        ("full", "max_goals=1 goals are open"),
        ("late", "it came in iteration 0"),
        ("feedback_after_end", "publish_feedback(goal 1): goal 1 is not open"),
        ("undecided", "was never decided"),
    ],
)
def test_forbidden_calls_raise_naming_component_and_action(act: str, words: str) -> None:
    spec = rtcf.ComponentSpec("m", Misbehaving, params={"act": act})
    second: Any = Cancel(1) if act == "cancel_decided_as_goal" else Goal(Fibonacci.Goal(), id=2)
    with pytest.raises(rtcf.ComponentError) as info:
        run_components([spec], 4, actions={"/fib": {0: Goal(Fibonacci.Goal(), id=1), 1: second}})
    assert "'/m'" in str(info.value) and "'/fib'" in str(info.value)
    assert words in str(info.value)


def test_action_ports_are_ordinary_ports() -> None:
    trace = run_components([FibServer], 1)
    comp = trace.components["/FibServer"]
    assert comp.inputs["~/fibonacci/_action/requests"].topic == NAME + "/_action/requests"
    assert comp.outputs["~/fibonacci/_action/events"].topic == NAME + "/_action/events"
    assert comp.fib.name == NAME and comp.fib.type is Fibonacci


def test_a_type_without_goal_result_feedback_is_refused() -> None:
    class Bad(rtcf.Component):
        def configure(self) -> None:
            self.add_action_server("x", int)

    with pytest.raises(rtcf.ComponentError, match="has no Goal, Result, Feedback"):
        run_components([Bad], 1)


def test_an_unknown_action_name_names_the_served_ones() -> None:
    with pytest.raises(rtcf.ConfigurationError, match=f"the actions served: {NAME}"):
        run_components([FibServer], 1, actions={"/nope": {0: Cancel(1)}})


def test_deactivate_aborts_open_goals_and_configure_again_keeps_the_server() -> None:
    from rtcf._core._action_protocol import ActionEndpoint

    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    comp = runner.load(rtcf.ComponentSpec("FibServer", FibServer))
    server = comp.fib
    client = ActionEndpoint(NAME)
    server._events._tap = lambda event: client.receive(event, runner.state.iteration)
    slot = server._requests._slot
    slot.value, slot.seq = client.goal_request(Fibonacci.Goal(100), 1), slot.seq + 1
    try:
        runner.run(3)
        assert server.active == (1,)
        assert runner.change_state("/FibServer", "deactivate").result == "success"
        assert server.active == () and client.goals[1].status == S.ABORTED
        runner.change_state("/FibServer", "cleanup")
        runner.change_state("/FibServer", "configure")
        assert comp.fib is server
    finally:
        runner.shutdown()


def test_a_refused_decision_leaves_the_request_to_be_rejected_at_stop() -> None:
    from rtcf._core._action_protocol import ActionEndpoint

    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    comp = runner.load(rtcf.ComponentSpec("m", Misbehaving, params={"act": "full"}))
    client = ActionEndpoint("/fib")
    comp.fib._events._tap = lambda event: client.receive(event, runner.state.iteration)
    goals = [client.goal_request(Fibonacci.Goal(), 1), client.goal_request(Fibonacci.Goal(), 2)]
    port = comp.fib._requests

    def feed() -> None:
        if goals and not port.has_new_data:
            port._slot.value = goals.pop(0)
            port._slot.seq += 1

    with pytest.raises(rtcf.ComponentError, match="max_goals=1"):
        runner.run(3, feeders=[feed])
    runner.shutdown()
    assert client.goals[1].states[-1][1] == S.ABORTED  # open at the stop
    assert client.goals[2].accepted is False  # its accept was refused: rejected at the stop


class Steady(rtcf.Component):
    """Accepts each goal, sends it feedback in 3 iterations, then succeeds it: all with
    messages made in configure, so that what it allocates per call is the server's."""

    def configure(self) -> None:
        self.fib = self.add_action_server("~/fibonacci", Fibonacci)
        self.feedback, self.result = Fibonacci.Feedback([1]), Fibonacci.Result([1])
        self.left = 0

    def update(self) -> None:
        req = self.fib.request()
        if req is not None:
            self.fib.accept(req)
            self.left = 3
        for goal_id in self.fib.active:
            if self.left:
                self.left -= 1
                self.fib.publish_feedback(goal_id, self.feedback)
            else:
                self.fib.succeed(goal_id, self.result)


def _server_blocks(cycles: int) -> int:
    """Live blocks that the action server's modules allocated during ``cycles`` goals
    (accept, 3 feedback, result), with a tap that keeps every event written."""
    import tracemalloc

    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    comp = runner.load(rtcf.ComponentSpec("Steady", Steady))
    kept: list[Any] = []
    comp.fib._events._tap = kept.append
    requests = [ActionRequest(ActionRequest.GOAL, k + 1000, b"", Fibonacci.Goal(1))
                for k in range(cycles)]  # made here: a bridge's feeder makes them
    port = comp.fib._requests

    def feed() -> None:
        if requests and not port.has_new_data and not comp.fib.active:
            port._slot.value = requests.pop()
            port._slot.seq += 1

    try:
        runner.run(2, feeders=[feed])  # warm: the first goal's tuple, caches
        tracemalloc.start()
        runner.run(cycles * 5, feeders=[feed])
        snapshot = tracemalloc.take_snapshot().filter_traces([
            tracemalloc.Filter(True, "*/rtcf/_core/_action*.py")])
        tracemalloc.stop()
    finally:
        runner.shutdown()
    assert len(kept) >= cycles * 4  # accept, feedback x3, result: every one tapped
    return len(snapshot.traces)


def test_decisions_feedback_and_results_allocate_nothing_per_call() -> None:
    # every tapped event is kept alive: one object per write would stay allocated
    assert _server_blocks(10) == _server_blocks(40) <= 1  # at most `active`'s tuple


def test_the_events_are_preallocated_objects_and_the_testing_trace_copies_them() -> None:
    trace = run_components([FibServer], 6, actions={NAME: {1: Goal(Fibonacci.Goal(3), id=1)}})
    server = trace.components["/FibServer"].fib
    assert any(server._events._slot.value is e for e in server._events_made)
    goal = trace.actions[NAME].goals[1]
    assert [fb.sequence for _, fb in goal.feedback] == [[0, 1, 1], [0, 1, 1, 2]]
    assert goal.states[-1][1] == S.SUCCEEDED and goal.result == Fibonacci.Result([0, 1, 1, 2])


def _fake_message(name: str) -> type:
    return type(name, (), {
        "get_fields_and_field_types": classmethod(lambda cls: {"x": "double"}),
        "__module__": "actfake.msg",
    })


def test_a_serialized_of_another_class_is_refused_naming_the_action() -> None:
    class Act:
        Goal = _fake_message("Goal")
        Feedback = _fake_message("Feedback")
        Result = _fake_message("Result")

    class Server(rtcf.Component):
        def configure(self) -> None:
            self.act = self.add_action_server("act", Act)
            self.fb = rtcf.Serialized(Act.Feedback)
            self.wrong = rtcf.Serialized(Act.Result)

        def update(self) -> None:
            req = self.act.request()
            if req is not None:
                self.act.accept(req)
            for goal_id in self.act.active:
                self.fb.x = 2.0
                self.act.publish_feedback(goal_id, self.fb)
                self.act.publish_feedback(goal_id, self.wrong)

    with pytest.raises(rtcf.ComponentError, match=r"action '/act': publish_feedback: a "
                       r"Serialized\(Result\) given where Act's Feedback is expected"):
        run_components([Server], 3, actions={"/act": {0: Goal(Act.Goal(), id=1)}})


def test_a_request_taken_after_its_deadline_is_dropped_and_counted() -> None:
    """The bridge tells the client "rejected" at the request's deadline: a component
    that takes it later (one that runs slower than the loop, or polls) must not run it."""
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    comp = runner.load(rtcf.ComponentSpec("Steady", Steady))
    now = time.monotonic_ns()
    late = ActionRequest(ActionRequest.GOAL, 1, b"", Fibonacci.Goal(1), deadline_ns=now - 1)
    timely = ActionRequest(ActionRequest.GOAL, 2, b"", Fibonacci.Goal(1), deadline_ns=now + 10**12)
    requests = [timely, late]
    port = comp.fib._requests

    def feed() -> None:
        if requests and not port.has_new_data:
            port._slot.value = requests.pop()
            port._slot.seq += 1

    try:
        runner.run(1, feeders=[feed])
        assert comp.fib.active == () and comp.fib.expired == 1
        runner.run(1, feeders=[feed])
        assert comp.fib.active == (2,) and comp.fib.expired == 1
    finally:
        runner.shutdown()
