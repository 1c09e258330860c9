"""The action protocol's vocabulary: goal states, their table, requests and events.

A ROS action (rcl_action) is a goal's state machine between a client and a server.
rtcf carries it over two ordinary ports of the serving component: one input of
:class:`ActionRequest` (a goal, or a cancel of one) and one output of
:class:`ActionEvent` (a response to a request, feedback, a result). One channel each
way keeps the protocol's order: a cancel never overtakes its goal, an accept reaches
the client before the goal's result.

:class:`ActionEndpoint` is the client's side of the same table with no middleware:
what ``rtcf.testing`` feeds and records, and what a bridge keeps per action.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ._cdr import Serialized


class GoalStatus(enum.IntEnum):
    """A goal's state, with the numbers of ``action_msgs/msg/GoalStatus``."""

    UNKNOWN = 0
    ACCEPTED = 1
    EXECUTING = 2
    CANCELING = 3
    SUCCEEDED = 4
    CANCELED = 5
    ABORTED = 6


UNKNOWN, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = GoalStatus
TERMINAL = frozenset((SUCCEEDED, CANCELED, ABORTED))

# request kinds (ActionRequest.kind)
GOAL = 1
CANCEL = 2
# event kinds (ActionEvent.kind)
RESPONSE = 1
FEEDBACK = 2
RESULT = 3
# a RESPONSE's flags: the request it answers was accepted; it answers a cancel
FLAG_ACCEPTED = 1
FLAG_CANCEL = 2

# rcl_action's goal state machine: (status, event) -> status. The events are named
# by the status they lead to; EXECUTING is the execute event, CANCELING the cancel.
_TABLE: dict[tuple[int, int], GoalStatus] = {
    (ACCEPTED, EXECUTING): EXECUTING,
    (ACCEPTED, CANCELING): CANCELING,
    (EXECUTING, CANCELING): CANCELING,
    (EXECUTING, SUCCEEDED): SUCCEEDED,
    (EXECUTING, ABORTED): ABORTED,
    (CANCELING, SUCCEEDED): SUCCEEDED,
    (CANCELING, ABORTED): ABORTED,
    (CANCELING, CANCELED): CANCELED,
}


def next_status(status: int, event: int) -> GoalStatus | None:
    """The status ``event`` leads to from ``status``, or None if the table forbids it."""
    return _TABLE.get((status, event))


@dataclass(slots=True, eq=False, repr=False)
class ActionRequest:
    """What reaches an action server's component: a goal, or a request to cancel one.

    ``kind`` is ``GOAL`` or ``CANCEL``; ``goal_id`` numbers the goal within the run
    (the cancel's: the goal it cancels); ``uuid`` is the client's 16-byte goal id;
    ``goal`` the action's ``Goal`` message (None for a cancel); ``deadline_ns`` when
    (``time.monotonic_ns()``) its client is told "rejected" if the component has not
    answered (0: never).
    """

    GOAL: ClassVar[int] = GOAL
    CANCEL: ClassVar[int] = CANCEL

    kind: int
    goal_id: int
    uuid: bytes = b""
    goal: Any = None
    deadline_ns: int = 0
    iteration: int = field(default=-1, init=False)  # the iteration the server handed it out in

    def __repr__(self) -> str:
        what = "GOAL" if self.kind == GOAL else "CANCEL"
        return f"<ActionRequest {what} {self.goal_id}>"


@dataclass(slots=True, eq=False, repr=False)
class ActionEvent:
    """What an action server's component tells its clients: ``kind`` RESPONSE (to a
    request: ``flags`` say which and whether accepted), FEEDBACK or RESULT, about
    ``goal_id``, with the goal's ``status`` after it and a ``message`` (Feedback,
    Result, or None)."""

    RESPONSE: ClassVar[int] = RESPONSE
    FEEDBACK: ClassVar[int] = FEEDBACK
    RESULT: ClassVar[int] = RESULT

    kind: int
    goal_id: int
    status: int
    message: Any = None
    flags: int = 0

    @property
    def accepted(self) -> bool:
        return bool(self.flags & FLAG_ACCEPTED)

    def __repr__(self) -> str:
        kind = {RESPONSE: "RESPONSE", FEEDBACK: "FEEDBACK", RESULT: "RESULT"}[self.kind]
        return f"<ActionEvent {kind} {self.goal_id} {GoalStatus(self.status).name}>"


@dataclass
class GoalRecord:
    """One goal as its client saw it: ``accepted`` (None until answered), every
    ``states`` change as ``(iteration, status)``, ``feedback`` as ``(iteration,
    message)``, the last ``status``, its ``result``, and ``cancel_accepted`` (None
    when no cancel was answered)."""

    goal: Any = None
    accepted: bool | None = None
    states: list[tuple[int, GoalStatus]] = field(default_factory=list)
    feedback: list[tuple[int, Any]] = field(default_factory=list)
    status: GoalStatus = UNKNOWN
    result: Any = None
    cancel_accepted: bool | None = None

    def _enter(self, iteration: int, status: int) -> None:
        self.status = GoalStatus(status)
        self.states.append((iteration, self.status))


class ActionEndpoint:
    """The client's side of one action, with no middleware: it numbers goals, makes
    the requests, and follows every event into a :class:`GoalRecord` per goal."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.goals: dict[int, GoalRecord] = {}

    def goal_request(self, goal: Any, goal_id: int, uuid: bytes | None = None) -> ActionRequest:
        if goal_id in self.goals:
            raise ValueError(f"action {self.name!r}: goal id {goal_id} is given twice")
        self.goals[goal_id] = GoalRecord(goal=goal)
        return ActionRequest(GOAL, goal_id, uuid or goal_uuid(goal_id), goal)

    def cancel_request(self, goal_id: int) -> ActionRequest:
        return ActionRequest(CANCEL, goal_id, goal_uuid(goal_id))

    def receive(self, event: ActionEvent, iteration: int) -> None:
        """Follow one event the server wrote in ``iteration``."""
        record = self.goals.setdefault(event.goal_id, GoalRecord())
        if event.kind == RESPONSE:
            if event.flags & FLAG_CANCEL:
                record.cancel_accepted = event.accepted
                if event.accepted:
                    record._enter(iteration, CANCELING)
            else:
                record.accepted = event.accepted
                if event.accepted:  # accepted, and executing at once (rclpy's default)
                    record._enter(iteration, ACCEPTED)
                    record._enter(iteration, EXECUTING)
        elif event.kind == FEEDBACK:
            record.feedback.append((iteration, _kept(event.message)))
        else:
            record.result = _kept(event.message)
            record._enter(iteration, event.status)


def _kept(message: Any) -> Any:
    """A message as it was when written: a Serialized is rewritten in place by its
    writer, so its rosidl message is kept."""
    return message.to_message() if type(message) is Serialized else message


def goal_uuid(goal_id: int) -> bytes:
    """A 16-byte goal UUID derived from the goal's number (tests, replays)."""
    return goal_id.to_bytes(16, "big")
