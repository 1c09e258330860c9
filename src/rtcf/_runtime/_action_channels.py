"""Actions mapped to the middleware: their two rings, and the records in them.

A mapped action crosses the process boundary in two rings of the run's port segment
(``_port_channels`` lays them out beside the topics'): the supervisor writes the
requests ring (goals and cancels, with the client's UUID) and the worker's
:class:`RequestFeeder` hands at most one record per iteration to the action's
requests input, once the component took the last; the worker's :class:`EventTap`
writes every event of the action's events output into the events ring, as a mapped
output's tap does, and the supervisor drains it when the doorbell rings. One ring
each way keeps the protocol's order.

A record: ``<BBHI`` (kind, status, flags, goal_id), a request's 16-byte UUID, a
uint32 length, a request's deadline, then the message's CDR bytes (Goal, Feedback or
Result; none for a cancel, a response, or an empty result). A request still waiting
at its deadline (CLOCK_MONOTONIC, which both processes share) is dropped, never handed
to the component: its client was answered "rejected" by then (a component that was
inactive, or a loop that stalled, must not run a goal that nobody follows).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable, Iterator
from typing import Any

from .._core._action_protocol import GOAL, ActionEvent, ActionRequest
from .._core._errors import ConfigurationError
from .._core._ports import InputPort
from .._core._rings import Ring
from ._codec import Codec, codec_for

REQUESTS = "action_requests"  # MappedPort.direction of the requests ring
EVENTS = "action_events"  # ... and of the events ring
REQUEST_RECORDS = 8
EVENT_RECORDS = 64
ACTION_EVENT_BYTES = 16 * 1024
_REQUEST = struct.Struct("<BBHI16sIQ")
_EVENT = struct.Struct("<BBHII")


def ring_shape(direction: str, goal_bytes: int) -> tuple[int, int]:
    """(records, record size) of an action's ring in ``direction``; ``goal_bytes``: the
    largest goal (the runner's ``action_max_goal_bytes``)."""
    if direction == REQUESTS:
        return REQUEST_RECORDS, _REQUEST.size + goal_bytes
    return EVENT_RECORDS, _EVENT.size + ACTION_EVENT_BYTES


def goal_room(ring: Ring) -> int:
    """The largest goal (CDR bytes) the requests ring takes."""
    return ring.record_size - _REQUEST.size


def message_codecs(action: str, action_type: type) -> dict[str, Codec]:
    """The codecs of an action's Goal, Feedback and Result (ROS 2 message classes)."""
    codecs = {}
    for part in ("Goal", "Feedback", "Result"):
        codec = codec_for(getattr(action_type, part))
        if codec is None or codec.kind != "ros2":
            raise ConfigurationError(
                f"action {action} ({action_type.__name__}) is mapped to the middleware "
                "(ros_mapping_whitelist), but its type is no ROS 2 action, and actions are "
                "served on ROS 2 only: serve a ROS 2 action type (e.g. "
                "control_msgs.action.FollowJointTrajectory) with --middleware ros2, or leave "
                "the action out of the whitelist"
            )
        codecs[part] = codec
    return codecs


# -- the supervisor's side ----------------------------------------------------------
def push_request(
    ring: Ring, kind: int, goal_id: int, uuid: bytes, cdr: bytes = b"", deadline_ns: int = 0
) -> bool:
    """Write one request, to be dropped if still waiting at ``deadline_ns`` (monotonic;
    0: never); False if it is larger than the ring's records (see :func:`goal_room`) or
    the ring is full (the caller rejects it)."""
    if len(cdr) > ring.record_size - _REQUEST.size:
        return False
    off = ring.reserve()
    if off < 0:
        return False
    _REQUEST.pack_into(ring.data, off, kind, 0, 0, goal_id, uuid, len(cdr), deadline_ns)
    start = off + _REQUEST.size
    ring.data[start : start + len(cdr)] = cdr
    ring.commit()
    return True


def drain_events(ring: Ring) -> Iterator[tuple[int, int, int, int, bytes]]:
    """Every waiting event as (kind, status, flags, goal_id, CDR bytes), oldest first."""
    while True:
        start, n = ring.pending()
        if n == 0:
            return
        for slot in range(start, start + n):
            off = slot * ring.record_size
            kind, status, flags, goal_id, length = _EVENT.unpack_from(ring.data, off)
            begin = off + _EVENT.size
            yield kind, status, flags, goal_id, bytes(ring.data[begin : begin + length])
        ring.release(n)


# -- the worker's side ----------------------------------------------------------------
class RequestFeeder:
    """Hands the oldest waiting request to the action's requests input, once the
    component took the one before (called behind the ring's gate: only when records
    wait; a request allocates only then)."""

    __slots__ = ("_decode", "_port", "_ring", "delivered", "expired")

    def __init__(self, ring: Ring, port: InputPort[Any], goal: Codec) -> None:
        self._ring = ring
        self._port = port
        self._decode = goal.decode
        self.delivered = 0
        self.expired = 0  # dropped at their deadline (their clients got "rejected")

    def __call__(self) -> None:
        port = self._port
        if port.has_new_data:  # the component has not taken the last one yet
            return
        ring = self._ring
        slot, n = ring.pending()
        if n == 0:
            return
        data = ring.data
        off = slot * ring.record_size
        kind, _, _, goal_id, uuid, length, deadline = _REQUEST.unpack_from(data, off)
        if deadline and time.monotonic_ns() > deadline:
            ring.release(1)
            self.expired += 1
            return
        goal = None
        if kind == GOAL:
            begin = off + _REQUEST.size
            goal = self._decode(bytes(data[begin : begin + length]))
        ring.release(1)
        req = ActionRequest(kind, goal_id, uuid, goal, deadline)
        s = port._slot
        s.value = req
        s.seq += 1
        self.delivered += 1


class EventTap:
    """Encodes every event an action's events output writes into the events ring."""

    __slots__ = ("_encode", "_max", "_pushed", "_ring", "oversize")

    def __init__(self, ring: Ring, codecs: dict[str, Codec], pushed: list[int]) -> None:
        self._ring = ring
        self._pushed = pushed  # the run's flag: the doorbell rings after the iteration
        feedback, result = codecs["Feedback"].encode, codecs["Result"].encode
        self._encode: dict[int, Callable[[Any], bytes]] = {
            ActionEvent.FEEDBACK: feedback, ActionEvent.RESULT: result,
        }
        self._max = ring.record_size - _EVENT.size
        self.oversize = 0

    def __call__(self, event: ActionEvent) -> None:
        message = event.message
        cdr = b"" if message is None else self._encode[event.kind](message)
        if len(cdr) > self._max:
            self.oversize += 1
            if event.kind == ActionEvent.FEEDBACK:
                return
            cdr = b""  # a result must reach the client: an empty one, counted
        ring = self._ring
        off = ring.reserve()
        if off < 0:
            return  # the ring counts the drop
        _EVENT.pack_into(ring.data, off, event.kind, event.status, event.flags,
                         event.goal_id, len(cdr))
        begin = off + _EVENT.size
        ring.data[begin : begin + len(cdr)] = cdr
        ring.commit()
        self._pushed[0] = 1
