"""Mapped actions on ROS 2: rclpy's action server in the supervisor, the goals in the loop.

Per mapped action, one ``rclpy.action.ActionServer`` on the runner's node. Its
callbacks are coroutines: a goal is pushed into the action's requests ring and the
callback awaits the component's answer, which the drain (woken by the worker's
doorbell) reads from the events ring; rclpy resumes a waiting coroutine at the
executor's next wake-up, so nothing blocks the executor. The server has a
``ReentrantCallbackGroup`` of its own: rclpy holds a callback's group for the
coroutine's whole life, and in the node's default group a waiting goal would stall
every service and subscription of the bridge.

rclpy's protocol points that shape this: ``goal_callback`` gets the Goal only (its
UUID is taken where rclpy unpacks the request); the accepted goal's handle is found
by its request object; a cancel is applied (CANCELING) only after ``cancel_callback``
returns, so a CANCELED result may have to wait for it. Feedback is decoded and
published through rclpy's goal handle in the drain, so a goal's feedback precedes its
result as the loop wrote them; feedback that comes before rclpy's accept waits for it
(rclpy publishes feedback only as message objects: publishing the loop's bytes would
take rcl_action's private server struct or a second writer in the graph, and a
decode costs the drain 11-71 µs per feedback, outside the loop). No answer within
``RESPONSE_TIMEOUT_S``: the goal (or cancel) is rejected; a component that is not
active: rejected at once; a run that ends: its open goals are aborted.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .._core._action_protocol import (
    ABORTED,
    CANCEL,
    CANCELED,
    FEEDBACK,
    FLAG_ACCEPTED,
    FLAG_CANCEL,
    GOAL,
    RESPONSE,
    SUCCEEDED,
)
from .._core._message_types import message_class
from .._core._rings import Mailbox, Ring
from .._runtime._action_channels import (
    REQUESTS,
    drain_events,
    goal_room,
    push_request,
)
from .._runtime._port_channels import MailboxFanOut, MappedPort

RESPONSE_TIMEOUT_S = 1.0  # a goal or cancel the loop has not taken by then: rejected
# how long after its deadline an answer to a request handed over just before it may
# take (an iteration, the doorbell, the drain); the worker drops it at the deadline
GRACE_S = 0.5
_ZERO_UUID = bytes(16)


def deadline_ns() -> int:
    """When the worker drops a request not yet handed to the component."""
    return time.monotonic_ns() + round(RESPONSE_TIMEOUT_S * 1e9)


class _Yield:
    """Awaited in an rclpy coroutine: give the executor back until its next wake-up."""

    def __await__(self) -> Any:
        yield


@dataclass
class _Goal:
    goal_id: int
    accepted: bool | None = None  # the component's answer (None: none yet)
    cancel: bool | None = None  # the answer to a pending cancel
    handle: Any = None  # rclpy's ServerGoalHandle, once accepted
    result: tuple[int, bytes] | None = None  # (status, Result CDR), once ended
    early: list[bytes] = field(default_factory=list)  # feedback CDR before the handle


class _Served:
    """One mapped action: its rclpy server, its rings while a run is open, its goals."""

    def __init__(
        self, node: Any, action_type: type, name: str, component: str, bridge: ActionBridge
    ) -> None:
        from rclpy.action import ActionServer
        from rclpy.callback_groups import ReentrantCallbackGroup

        self.type: Any = action_type
        self.name = name
        self.component = component
        self._bridge = bridge
        self.requests: Ring | None = None
        self.events: Ring | None = None
        self.goals: dict[int, _Goal] = {}
        self._by_request: dict[int, int] = {}  # id(Goal message) -> goal_id
        self._uuids: dict[int, bytes] = {}  # id(Goal message) -> the client's UUID
        self._next_id = 1
        served = self

        class Server(ActionServer):
            async def _execute_goal_request(self, request_header_and_message: Any) -> Any:
                # the one place that sees a goal's UUID with its Goal message
                goal_request = request_header_and_message[1]
                served._uuids[id(goal_request.goal)] = bytes(goal_request.goal_id.uuid)
                return await super()._execute_goal_request(request_header_and_message)

        self.server = Server(
            node, action_type, name, self._execute,
            goal_callback=self._on_goal,
            handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel,
            callback_group=ReentrantCallbackGroup(),
        )

    # -- rclpy's callbacks (the executor's thread) -----------------------------------
    async def _on_goal(self, goal: Any) -> Any:
        from rclpy.action import GoalResponse
        from rclpy.serialization import serialize_message

        uuid = self._uuids.pop(id(goal), _ZERO_UUID)
        bridge = self._bridge
        if not bridge.is_active(self.component):  # as ros2_controllers' do
            return GoalResponse.REJECT
        cdr = serialize_message(goal)
        with bridge.lock:
            if self.requests is not None and len(cdr) > goal_room(self.requests):
                bridge.warn(f"action {self.name}: a goal of {len(cdr)} bytes is larger than "
                            f"action_max_goal_bytes ({goal_room(self.requests)}); rejected")
                return GoalResponse.REJECT
            goal_id = self._next_id
            self._next_id += 1
            record = _Goal(goal_id)
            if self.requests is None or not push_request(
                self.requests, GOAL, goal_id, uuid, cdr, deadline_ns()
            ):
                return GoalResponse.REJECT  # no run, or too many requests waiting
            self.goals[goal_id] = record
            self._by_request[id(goal)] = goal_id
        answered = await bridge.answer(lambda: record.accepted is not None)
        with bridge.lock:
            if answered and record.accepted:
                return GoalResponse.ACCEPT
            self.goals.pop(goal_id, None)
            self._by_request.pop(id(goal), None)
        if not answered:
            bridge.warn(f"action {self.name}: goal {goal_id} got no answer from the loop in "
                        f"{RESPONSE_TIMEOUT_S:g} s; rejected")
        return GoalResponse.REJECT

    def _on_accepted(self, handle: Any) -> None:
        with self._bridge.lock:  # held: the drain's feedback comes after the early one
            goal_id = self._by_request.pop(id(handle.request), None)
            record = self.goals.get(goal_id) if goal_id is not None else None
            handle.execute()  # EXECUTING at once, as the component's table says
            if record is not None:
                record.handle = handle
                early, record.early = record.early, []
                for cdr in early:
                    self._publish_feedback(record, cdr)

    async def _on_cancel(self, handle: Any) -> Any:
        from rclpy.action import CancelResponse

        bridge = self._bridge
        with bridge.lock:
            record = self._record_of(handle)
            if (record is None or record.result is not None or self.requests is None
                    or not bridge.is_active(self.component)):
                return CancelResponse.REJECT
            record.cancel = None
            if not push_request(self.requests, CANCEL, record.goal_id,
                                bytes(handle.goal_id.uuid), b"", deadline_ns()):
                return CancelResponse.REJECT
        answered = await bridge.answer(lambda: record.cancel is not None)
        return CancelResponse.ACCEPT if answered and record.cancel else CancelResponse.REJECT

    async def _execute(self, handle: Any) -> Any:
        from rclpy.serialization import deserialize_message

        bridge = self._bridge
        record = self._record_of(handle)
        if record is None:  # the run closed before it was accepted here
            handle.abort()
            return self.type.Result()
        while record.result is None:
            await _Yield()
        status, cdr = record.result
        if status == CANCELED:  # rclpy applies the cancel after its callback returned
            await bridge.answer(lambda: handle.is_cancel_requested, wake=True)
            if not handle.is_cancel_requested:
                status = ABORTED
        with bridge.lock:
            self.goals.pop(record.goal_id, None)
        result = deserialize_message(cdr, self.type.Result) if cdr else self.type.Result()
        if status == SUCCEEDED:
            handle.succeed()
        elif status == CANCELED:
            handle.canceled()
        else:
            handle.abort()
        return result

    def _record_of(self, handle: Any) -> _Goal | None:
        for record in self.goals.values():
            if record.handle is handle:
                return record
        return None

    # -- the drain (the publishing thread, bridge lock held) -------------------------
    def drain(self) -> bool:
        """Apply every event the loop wrote; whether there were any."""
        if self.events is None:
            return False
        any_event = False
        for kind, status, flags, goal_id, cdr in drain_events(self.events):
            any_event = True
            record = self.goals.get(goal_id)
            if record is None:  # rejected here meanwhile (a late answer): nothing waits
                continue
            if kind == RESPONSE:
                accepted = bool(flags & FLAG_ACCEPTED)
                if flags & FLAG_CANCEL:
                    record.cancel = accepted
                else:
                    record.accepted = accepted
            elif kind == FEEDBACK:
                if record.handle is not None:
                    self._publish_feedback(record, cdr)
                else:
                    record.early.append(cdr)
            else:
                record.result = (status, cdr)
        return any_event

    def _publish_feedback(self, record: _Goal, cdr: bytes) -> None:
        """One feedback, in the drain (or at the accept, for the early ones)."""
        from rclpy.serialization import deserialize_message

        record.handle.publish_feedback(deserialize_message(cdr, self.type.Feedback))

    def close_run(self) -> None:
        """The run ended: what waits is answered, open goals end ABORTED."""
        self.requests = self.events = None
        for record in self.goals.values():
            if record.accepted is None:
                record.accepted = False
            if record.cancel is None:
                record.cancel = False
            if record.result is None:
                record.result = (ABORTED, b"")


class ActionBridge:
    """The mapped actions of a runner's node, served by the bridge's executor."""

    def __init__(
        self, node: Any, executor: Any, is_active: Callable[[str], bool],
    ) -> None:
        self.node = node
        self.executor = executor
        self.is_active = is_active
        self.lock = threading.Lock()
        self._served: dict[str, _Served] = {}

    def open(
        self, ports: list[MappedPort], channels: Mapping[str, Ring | Mailbox | MailboxFanOut]
    ) -> None:
        """Serve the run's mapped actions (a server made once per action and kept while
        runs map it; one no run maps any more leaves the graph)."""
        mapped = {p.topic.removesuffix("/_action/requests") for p in ports
                  if p.direction == REQUESTS}
        for gone in [name for name in self._served if name not in mapped]:
            self._served.pop(gone).server.destroy()
        for port in ports:
            if port.direction != REQUESTS:
                continue
            name = port.topic.removesuffix("/_action/requests")
            action_type = message_class(port.type_name)
            served = self._served.get(name)
            if served is None or served.type is not action_type:
                if served is not None:
                    served.server.destroy()
                served = _Served(self.node, action_type, name, port.component, self)
                self._served[name] = served
            requests = channels[port.topic]
            events = channels[name + "/_action/events"]
            assert isinstance(requests, Ring) and isinstance(events, Ring)
            with self.lock:
                served.component = port.component
                served.requests, served.events = requests, events

    def drain(self) -> None:
        """After the doorbell (and every spin timeout): the loop's answers, feedback and
        results to rclpy; its executor woken when a coroutine has something new."""
        with self.lock:
            woke = [s.drain() for s in self._served.values()]
        if any(woke):
            self.wake()

    def close_run(self) -> None:
        with self.lock:
            for served in self._served.values():
                served.drain()
                served.close_run()
        self.wake()

    def shutdown(self) -> None:
        for served in self._served.values():
            served.server.destroy()
        self._served.clear()

    # -- for the coroutines ------------------------------------------------------------
    async def answer(self, done: Callable[[], bool], *, wake: bool = False) -> bool:
        """Wait (without blocking the executor) until ``done()``; False after
        ``RESPONSE_TIMEOUT_S`` and its grace. ``wake``: resume at once instead of at the
        next wake-up (a wait of a few executor passes only)."""
        deadline = time.monotonic() + RESPONSE_TIMEOUT_S + GRACE_S
        while not done():
            if time.monotonic() > deadline:
                return False
            if wake:
                self.wake()
            await _Yield()
        return True

    def wake(self) -> None:
        wake = getattr(self.executor, "wake", None)
        if wake is not None:  # rclpy >= 7: at once; before, at the next spin timeout
            wake()

    def warn(self, text: str) -> None:
        self.node.get_logger().warning(text)

