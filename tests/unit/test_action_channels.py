"""An action's two rings: requests in (one per iteration), events out, the records."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest

import rtcf
from rtcf import ActionEvent, ActionRequest, GoalStatus
from rtcf._core._rings import Ring
from rtcf._runtime import _action_channels as ac
from rtcf._runtime._codec import Codec
from rtcf._runtime._port_channels import mapped_ports

from .test_actions import Fibonacci, FibServer


def _json_codec(cls: type) -> Codec:  # a stand-in for rclpy's CDR of a ROS 2 message
    return Codec("ros2", lambda v: json.dumps(vars(v)).encode(),
                 lambda b: cls(**json.loads(b)), 1 << 16)


CODECS = {part: _json_codec(getattr(Fibonacci, part)) for part in ("Goal", "Feedback", "Result")}


GOAL_BYTES = 4096


def _ring(direction: str) -> Ring:
    records, size = ac.ring_shape(direction, GOAL_BYTES)
    return Ring.create(bytearray(Ring.nbytes(records, size)), records, size)


def _goal(order: int) -> bytes:
    return CODECS["Goal"].encode(Fibonacci.Goal(order))


def _serve(
    requests: Ring, events: Ring, iterations: int, cls: type = FibServer
) -> tuple[rtcf.Runner, Any, Any]:
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    server = runner.load(rtcf.ComponentSpec("FibServer", cls)).fib
    feeder = ac.RequestFeeder(requests, server._requests, CODECS["Goal"])
    gate = requests.when_pending(feeder)
    tap = ac.EventTap(events, CODECS, [0])
    server._events._tap = tap
    try:
        runner.run(iterations, feeders=[gate])
    finally:
        runner.shutdown()
        gate.release()
    return runner, feeder, tap


def test_goals_cross_one_per_iteration_and_every_event_comes_back_in_order() -> None:
    requests, events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    uuid = bytes(range(16))
    assert ac.push_request(requests, ActionRequest.GOAL, 1, uuid, _goal(-1))  # rejected
    assert ac.push_request(requests, ActionRequest.GOAL, 2, uuid, _goal(2))
    assert ac.push_request(requests, ActionRequest.CANCEL, 9, uuid)  # a goal never seen
    _, feeder, _ = _serve(requests, events, 6)
    assert feeder.delivered == 3 and len(requests) == 0
    got = [(k, GoalStatus(s), f, g, json.loads(c) if c else None)
           for k, s, f, g, c in ac.drain_events(events)]
    R, F, E = ActionEvent.RESPONSE, ActionEvent.FEEDBACK, ActionEvent.RESULT
    assert got == [
        (R, GoalStatus.UNKNOWN, 0, 1, None),  # iteration 0: goal 1 rejected
        (R, GoalStatus.EXECUTING, 1, 2, None),  # iteration 1: goal 2 accepted...
        (F, GoalStatus.EXECUTING, 0, 2, {"sequence": [0, 1, 1]}),
        (R, GoalStatus.UNKNOWN, 2, 9, None),  # iteration 2: the cancel of no open goal
        (E, GoalStatus.SUCCEEDED, 0, 2, {"sequence": [0, 1, 1]}),
    ]
    assert list(ac.drain_events(events)) == []


def test_the_component_sees_the_uuid_and_the_decoded_goal() -> None:
    requests, events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    seen: list[ActionRequest] = []

    class Keep(FibServer):
        def update(self) -> None:
            req = self.fib.request()
            if req is not None:
                seen.append(req)
                self.fib.reject(req)

    ac.push_request(requests, ActionRequest.GOAL, 5, b"u" * 16, _goal(7))
    _serve(requests, events, 2, Keep)
    assert [(r.kind, r.goal_id, r.uuid, r.goal) for r in seen] == [
        (ActionRequest.GOAL, 5, b"u" * 16, Fibonacci.Goal(7))
    ]


def test_a_goal_too_big_for_the_ring_is_refused_and_a_full_ring_too() -> None:
    requests = _ring(ac.REQUESTS)
    assert GOAL_BYTES <= ac.goal_room(requests) < GOAL_BYTES + 8  # records are 8-byte aligned
    big = b"x" * (ac.goal_room(requests) + 1)
    assert not ac.push_request(requests, ActionRequest.GOAL, 1, bytes(16), big)
    assert ac.push_request(requests, ActionRequest.GOAL, 1, bytes(16), big[:-1])
    assert requests.pop() is not None
    for goal_id in range(ac.REQUEST_RECORDS):
        assert ac.push_request(requests, ActionRequest.GOAL, goal_id, bytes(16), b"")
    assert not ac.push_request(requests, ActionRequest.GOAL, 99, bytes(16), b"")


def test_oversize_feedback_is_dropped_and_an_oversize_result_goes_empty() -> None:
    events = _ring(ac.EVENTS)
    tap = ac.EventTap(events, CODECS, [0])
    huge = Fibonacci.Result(list(range(ac.ACTION_EVENT_BYTES)))
    tap(ActionEvent(ActionEvent.FEEDBACK, 1, GoalStatus.EXECUTING, huge))
    tap(ActionEvent(ActionEvent.RESULT, 1, GoalStatus.SUCCEEDED, huge))
    assert tap.oversize == 2
    assert list(ac.drain_events(events)) == [
        (ActionEvent.RESULT, GoalStatus.SUCCEEDED, 0, 1, b"")
    ]


def test_actions_map_by_their_name_and_their_ports_never_as_topics() -> None:
    settings = rtcf.RunnerSettings(ros_mapping_whitelist="/FibServer/.*")
    runner = rtcf.Runner(settings, clock=rtcf.SimClock())
    runner.load(rtcf.ComponentSpec("FibServer", FibServer))
    try:
        assert runner.mapped_ports() == ([], [])  # the _action ports are no topics
        assert [a.name for a in runner.mapped_actions()] == ["/FibServer/fibonacci"]
        with pytest.raises(rtcf.ConfigurationError, match="served on ROS 2 only"):
            mapped_ports([], [], runner.mapped_actions())  # a plain-Python action type
    finally:
        runner.shutdown()
    only_ports = rtcf.RunnerSettings(ros_mapping_whitelist="/FibServer/fibonacci/_action/.*")
    runner = rtcf.Runner(only_ports, clock=rtcf.SimClock())
    runner.load(rtcf.ComponentSpec("FibServer", FibServer))
    try:
        assert runner.mapped_actions() == [] and runner.mapped_ports() == ([], [])
    finally:
        runner.shutdown()


def test_a_recording_of_every_topic_leaves_the_action_ports_out() -> None:
    from rtcf._runtime._recording import recorded_topics

    runner = rtcf.Runner(rtcf.RunnerSettings(), clock=rtcf.SimClock())
    comp = runner.load(rtcf.ComponentSpec("FibServer", FibServer))
    try:
        assert recorded_topics(comp.outputs.values(), comp.inputs.values(), ".*") == []
    finally:
        runner.shutdown()


def test_a_request_still_waiting_at_its_deadline_is_dropped() -> None:
    requests, events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    past = time.monotonic_ns() - 1
    ac.push_request(requests, ActionRequest.GOAL, 1, bytes(16), _goal(2), deadline_ns=past)
    ac.push_request(requests, ActionRequest.GOAL, 2, bytes(16), _goal(-1),
                    deadline_ns=time.monotonic_ns() + 60 * 10**9)
    _, feeder, _ = _serve(requests, events, 3)
    assert (feeder.expired, feeder.delivered) == (1, 1)
    assert [(k, g) for k, _, _, g, _ in ac.drain_events(events)] == [(ActionEvent.RESPONSE, 2)]


def test_a_request_handed_over_but_not_taken_is_rejected_when_the_component_stops() -> None:
    requests, events = _ring(ac.REQUESTS), _ring(ac.EVENTS)

    class Deaf(FibServer):
        def update(self) -> None:  # never takes a request
            pass

    ac.push_request(requests, ActionRequest.GOAL, 4, bytes(16), _goal(2))
    _serve(requests, events, 2, Deaf)
    assert list(ac.drain_events(events)) == [(ActionEvent.RESPONSE, GoalStatus.UNKNOWN, 0, 4, b"")]
