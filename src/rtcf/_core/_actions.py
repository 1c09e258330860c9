"""An action server served from the loop: goals and cancels in, decisions and results out.

``Component.add_action_server`` returns an :class:`ActionServer`. It sits on two
ordinary ports (``<action>/_action/requests`` in, ``<action>/_action/events`` out), so
the graph, recordings and lanes see nothing new, and it keeps the goals' states in a
table preallocated for ``max_goals`` open goals, moved only as rcl_action's state
machine allows (:mod:`._action_protocol`). A call the protocol forbids raises
:class:`ComponentError` in ``update``, in-process and on ROS alike.

The real-time path: ``request()`` with nothing waiting is one compare; a decision
moves a table entry and writes one event (the port's tap carries it to a bridge).
Nothing is allocated per call: the table and the :class:`ActionEvent` objects that
decisions, feedback and results are written as are made in ``configure``. Each write
takes the next of them, in rotation, and rewrites it: an input that reads the events
port (in another lane too) holds an event that no later write of this iteration or
the next changes (there are twice as many as one iteration can write: one decision,
and a feedback and a result per open goal), and a tap copies what it keeps at once,
as a bridge's and ``rtcf.testing``'s do; and
``active`` is a tuple built when it is read after the open goals changed, not per
read. Feedback and results may be :class:`rtcf.Serialized` of the action's
Feedback and Result: laid out in ``configure`` and rewritten in the loop, they cross
as their bytes with no message built.
"""

from __future__ import annotations

import time
from typing import Any

from ._action_protocol import (
    ABORTED,
    CANCEL,
    CANCELED,
    CANCELING,
    EXECUTING,
    FEEDBACK,
    FLAG_ACCEPTED,
    FLAG_CANCEL,
    GOAL,
    RESPONSE,
    RESULT,
    SUCCEEDED,
    UNKNOWN,
    ActionEvent,
    ActionRequest,
    GoalStatus,
    next_status,
)
from ._cdr import Serialized
from ._errors import ComponentError
from ._loop_state import LoopState
from ._names import validate_name
from ._ports import InputPort, OutputPort

_FREE = -1  # a table entry no goal holds


def check_action(component: str, name: str, action_type: type, max_goals: int) -> None:
    """Raise :class:`ComponentError` naming ``component`` and the action when
    ``add_action_server``'s arguments are wrong: a type without ``Goal``, ``Result`` and
    ``Feedback``, ``max_goals`` not a positive int, or an invalid name."""
    missing = [k for k in ("Goal", "Result", "Feedback") if not hasattr(action_type, k)]
    if missing:
        raise ComponentError(
            f"component {component!r}: action {name!r}: {action_type!r} has no "
            f"{', '.join(missing)}; pass an action type such as "
            "control_msgs.action.FollowJointTrajectory",
            component=component,
        )
    if not isinstance(max_goals, int) or max_goals < 1:
        raise ComponentError(
            f"component {component!r}: action {name!r}: max_goals must be an int "
            f">= 1, not {max_goals!r}",
            component=component,
        )
    problem = validate_name(name, what=f"component {component!r}: action name")
    if problem:
        raise ComponentError(problem, component=component)


class ActionServer:
    """One action a component serves: ``request()`` the next goal or cancel, decide
    it (``accept``/``reject``, ``accept_cancel``/``reject_cancel``) in the same
    iteration, ``publish_feedback`` while a goal runs, and end it with ``succeed``,
    ``abort`` or ``canceled``."""

    def __init__(
        self,
        component: str,
        name: str,
        action_type: type,
        requests: InputPort[ActionRequest],
        events: OutputPort[ActionEvent],
        max_goals: int,
        state: LoopState,
    ) -> None:
        self.component = component
        self.name = name  # the action's resolved name, what a client calls
        self.type = action_type
        self.max_goals = max_goals
        self._requests = requests
        self._events = events
        self._state = state
        self._ids = [_FREE] * max_goals  # the open goals' ids...
        self._status: list[GoalStatus] = [UNKNOWN] * max_goals  # ... and their states
        self._order = [_FREE] * max_goals  # the open goals' ids, oldest first...
        self._open = 0  # ... in its first _open entries
        self._active: tuple[int, ...] | None = ()  # None: to build at the next read
        self._pending: ActionRequest | None = None  # handed out, not yet decided
        self.expired = 0  # requests taken after their deadline: dropped, never handed out
        # the events written, in rotation: nothing is allocated per write, and an event
        # a reader holds stays as it was for two iterations' writes (one iteration
        # writes at most a decision, and a feedback and a result per open goal)
        self._events_made = tuple(ActionEvent(RESPONSE, 0, UNKNOWN)
                                  for _ in range(2 * (2 * max_goals + 1)))
        self._next_event = 0
        # a Serialized written as feedback or a result must be of these classes
        self._feedback_class = getattr(action_type, "Feedback", None)
        self._result_class = getattr(action_type, "Result", None)

    # -- requests and decisions ---------------------------------------------------
    def request(self) -> ActionRequest | None:
        """The next goal or cancel (at most one per iteration, in arrival order), or
        None. Decide it in this iteration. One taken after its deadline (its client
        has been told "rejected") is dropped and counted in ``expired``."""
        port = self._requests
        if not port.has_new_data:
            return None
        req = port.read()
        if req is None:
            return None
        if req.deadline_ns and time.monotonic_ns() > req.deadline_ns:
            # handed over in time but taken late (a component that runs slower than the
            # loop, or polls): its client has been told "rejected" by now
            self.expired += 1
            return None
        if self._pending is not None:
            raise self._error(
                f"request {self._pending!r} of iteration {self._pending.iteration} was never "
                "decided; answer each request in the iteration request() returns it"
            )
        if req.kind == CANCEL and self._index(req.goal_id) < 0:
            # the goal ended already (its result crossed the cancel): refused for it
            self._write(RESPONSE, req.goal_id, UNKNOWN, None, FLAG_CANCEL)
            return None
        req.iteration = self._state.iteration
        self._pending = req
        return req

    def accept(self, req: ActionRequest, preempt: Any = None) -> None:
        """Accept a goal: it is EXECUTING at once. With ``preempt=result``, every other
        open goal is then ABORTED with that result (a newer goal replaces them)."""
        self._decide(req, GOAL, "accept")
        goal_id = req.goal_id
        if preempt is None and self._index(_FREE) < 0:
            raise self._error(
                f"accept(goal {goal_id}): max_goals={self.max_goals} goals are open; "
                "reject it, accept it with preempt=result, or raise max_goals"
            )
        if self._index(goal_id) >= 0:
            raise self._error(f"accept(goal {goal_id}): goal {goal_id} is open already")
        self._check_serialized(preempt, self._result_class, "accept(preempt=...)")
        self._pending = None  # decided (a refused call leaves it to the stop's reject)
        self._write(RESPONSE, goal_id, EXECUTING, None, FLAG_ACCEPTED)
        if preempt is not None:
            while self._open:  # the oldest first, as they were opened
                self._end(self._order[0], ABORTED, preempt, "accept(preempt=...)")
        i = self._index(_FREE)
        self._ids[i] = goal_id
        self._status[i] = EXECUTING
        self._order[self._open] = goal_id
        self._open += 1
        self._active = None

    def reject(self, req: ActionRequest) -> None:
        """Refuse a goal: it never runs."""
        self._decide(req, GOAL, "reject")
        self._pending = None
        self._write(RESPONSE, req.goal_id, UNKNOWN, None, 0)

    def accept_cancel(self, req: ActionRequest) -> None:
        """Agree to cancel: the goal is CANCELING until ``canceled`` (or ``succeed``,
        ``abort``) ends it."""
        self._decide(req, CANCEL, "accept_cancel")
        i = self._move(req.goal_id, CANCELING, "accept_cancel")
        self._pending = None
        self._write(RESPONSE, req.goal_id, CANCELING, None, FLAG_CANCEL | FLAG_ACCEPTED)
        self._status[i] = CANCELING

    def reject_cancel(self, req: ActionRequest) -> None:
        """Refuse to cancel: the goal goes on."""
        self._decide(req, CANCEL, "reject_cancel")
        self._pending = None
        i = self._index(req.goal_id)
        status = self._status[i] if i >= 0 else UNKNOWN
        self._write(RESPONSE, req.goal_id, status, None, FLAG_CANCEL)

    # -- running goals ----------------------------------------------------------------
    @property
    def active(self) -> tuple[int, ...]:
        """The open goals' ids (EXECUTING or CANCELING), oldest first: a tuple, so
        goals may end while it is iterated (built at the first read after a change)."""
        active = self._active
        if active is None:
            active = self._active = tuple(self._order[: self._open])
        return active

    def status(self, goal_id: int) -> GoalStatus:
        """An open goal's state (UNKNOWN once it ended, or if it never was)."""
        i = self._index(goal_id)
        return self._status[i] if i >= 0 else UNKNOWN

    def publish_feedback(self, goal_id: int, feedback: Any) -> None:
        """Send ``feedback`` (the action's Feedback message, or an
        :class:`rtcf.Serialized` of it) about an open goal."""
        i = self._index(goal_id)
        if i < 0:
            raise self._error(f"publish_feedback(goal {goal_id}): goal {goal_id} is not open")
        self._check_serialized(feedback, self._feedback_class, "publish_feedback")
        self._write(FEEDBACK, goal_id, self._status[i], feedback, 0)

    def succeed(self, goal_id: int, result: Any = None) -> None:
        """End a goal SUCCEEDED with ``result`` (None: an empty Result)."""
        self._end(goal_id, SUCCEEDED, result, "succeed")

    def abort(self, goal_id: int, result: Any = None) -> None:
        """End a goal ABORTED with ``result``."""
        self._end(goal_id, ABORTED, result, "abort")

    def canceled(self, goal_id: int, result: Any = None) -> None:
        """End a CANCELING goal CANCELED with ``result``."""
        self._end(goal_id, CANCELED, result, "canceled")

    # -- the framework's ---------------------------------------------------------------
    def _abort_open(self) -> None:
        """After ``stop``: a request left undecided (or not taken) is rejected, open
        goals end ABORTED."""
        undecided = [self._pending]  # stop: not the loop's path, lists may be made
        self._pending = None
        if self._requests.has_new_data:  # handed over, not taken: not left for later
            undecided.append(self._requests.read())
        for req in undecided:
            if req is not None:
                flags = FLAG_CANCEL if req.kind == CANCEL else 0
                self._write(RESPONSE, req.goal_id, UNKNOWN, None, flags)
        while self._open:
            self._end(self._order[0], ABORTED, None, "stop")

    def _decide(self, req: ActionRequest, kind: int, verb: str) -> None:
        """Whether ``req`` may be decided now with ``verb``; the caller clears it once
        every check passed (a refused decision leaves it undecided)."""
        if req is not self._pending:
            raise self._error(
                f"{verb}({req!r}): not the request request() returned last, or decided already; "
                "decide each request once, in the iteration request() returns it"
            )
        if req.kind != kind:
            other = "accept/reject" if req.kind == GOAL else "accept_cancel/reject_cancel"
            raise self._error(f"{verb}({req!r}): a {req!r} is decided with {other}")
        if req.iteration != self._state.iteration:
            raise self._error(
                f"{verb}({req!r}): it came in iteration {req.iteration}; decide a request in "
                "the iteration request() returns it"
            )

    def _end(self, goal_id: int, status: GoalStatus, result: Any, verb: str) -> None:
        i = self._move(goal_id, status, verb)
        self._check_serialized(result, self._result_class, verb)
        self._ids[i] = _FREE
        self._status[i] = UNKNOWN
        order = self._order
        n = self._open - 1
        k = order.index(goal_id, 0, self._open)
        while k < n:  # close the gap, in place
            order[k] = order[k + 1]
            k += 1
        order[n] = _FREE
        self._open = n
        self._active = None
        self._write(RESULT, goal_id, status, result, 0)

    def _move(self, goal_id: int, status: GoalStatus, verb: str) -> int:
        i = self._index(goal_id)
        if i < 0:
            raise self._error(f"{verb}(goal {goal_id}): goal {goal_id} is not open")
        if next_status(self._status[i], status) is None:
            now = GoalStatus(self._status[i]).name
            raise self._error(
                f"{verb}(goal {goal_id}): the action protocol forbids {now} -> {status.name}"
            )
        return i

    def _index(self, goal_id: int) -> int:
        ids = self._ids
        for i in range(len(ids)):
            if ids[i] == goal_id:
                return i
        return -1

    def _write(self, kind: int, goal_id: int, status: int, message: Any, flags: int) -> None:
        i = self._next_event
        event = self._events_made[i]
        self._next_event = i + 1 if i + 1 < len(self._events_made) else 0
        event.kind = kind
        event.goal_id = goal_id
        event.status = status
        event.message = message
        event.flags = flags
        self._events.write(event)

    def _check_serialized(self, message: Any, cls: Any, verb: str) -> None:
        if type(message) is Serialized and message.message_class is not cls:
            raise self._error(
                f"{verb}: a Serialized({message.message_class.__name__}) given where "
                f"{self.type.__name__}'s {'Feedback' if cls is self._feedback_class else 'Result'}"
                " is expected; make it of that class"
            )

    def _error(self, message: str) -> ComponentError:
        return ComponentError(
            f"component {self.component!r}, action {self.name!r}: {message}",
            component=self.component,
        )

    def __repr__(self) -> str:
        return f"<ActionServer {self.name} [{self.type.__name__}]>"


def abort_open(component: Any) -> None:
    """After a component's ``stop``: its action servers abort what is open."""
    for server in getattr(component, "_rtcf_actions", {}).values():
        server._abort_open()


__all__ = ["CANCEL", "GOAL", "ActionServer", "abort_open"]
