"""Ports mapped to the middleware: their shared-memory channels on both sides.

An output port whose topic is mapped gets a *tap*: every ``write`` also encodes the
value and pushes it into a ring that the supervisor drains and publishes, so every
write reaches the middleware (or is counted as dropped). After an iteration in which
some tap pushed, the loop rings the supervisor's doorbell once. The inputs of a mapped topic
that no component inside the runner produces are fed from a latest-value mailbox:
at the start of each iteration a *feeder* looks at the mailbox's version and, when
the supervisor has written a new message, decodes it into the inputs' slot, so the
components of that iteration read the newest message. The supervisor lays all the
channels of a run out in one segment; the worker maps it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from .._core._actions import ActionServer
from .._core._errors import ConfigurationError
from .._core._message_types import type_name
from .._core._ports import InputPort, OutputPort, Port, Slot
from .._core._rings import Mailbox, Ring
from ._action_channels import EVENTS, REQUESTS, EventTap, RequestFeeder, message_codecs, ring_shape
from ._codec import Codec, codec_for
from ._doorbell import Doorbell

OUTPUT_RING_RECORDS = 64  # messages that may wait for the supervisor per output topic
_LEN = 8  # a record starts with the payload length (int64)


@dataclass(frozen=True)
class MappedPort:
    """One topic that crosses to the middleware, as both processes see it."""

    # "output" (published), "input" (subscribed), or an action's rings: "action_requests"
    # (the goals and cancels the bridge writes), "action_events" (what it serves)
    direction: str
    topic: str
    type_name: str  # "std_msgs/msg/Float64" (ROS 2), "std_msgs/Float64" (ROS 1), "builtins.float"
    kind: str  # the codec: float, int, bool, str, float_array, ros2, ros1
    max_size: int
    offset: int = 0  # in the run's port segment
    nbytes: int = 0
    component: str = ""  # an action's: the component that serves it
    deadline: float = 0.0  # an input's: the shortest deadline of the ports reading it


def mapped_ports(
    outputs: list[OutputPort[Any]],
    unfed_inputs: list[InputPort[Any]],
    actions: Sequence[ActionServer] = (),
    goal_bytes: int = 256 * 1024,
) -> list[MappedPort]:
    """The channels a run needs, one per mapped topic and two per mapped action (goals
    up to ``goal_bytes``), laid out one after the other."""
    out: list[MappedPort] = []
    offset = 0
    for server in sorted(actions, key=lambda a: a.name):
        message_codecs(server.name, server.type)  # a ROS 2 action, or say so now
        for direction, topic in ((REQUESTS, server._requests.topic),
                                 (EVENTS, server._events.topic)):
            records, record_size = ring_shape(direction, goal_bytes)
            size = (Ring.nbytes(records, record_size) + 63) // 64 * 64
            out.append(MappedPort(direction, topic, type_name(server.type), "action",
                                  record_size, offset, size, server.component))
            offset += size
    seen: set[str] = set()
    deadlines: dict[str, float] = {}  # per input topic, the shortest of its readers'
    for reader in unfed_inputs:
        if reader._deadline_ns > 0:
            d = reader._deadline_ns / 1e9
            deadlines[reader.topic] = min(d, deadlines.get(reader.topic, d))
    for direction, ports in (("output", outputs), ("input", unfed_inputs)):
        for port in sorted(ports, key=lambda p: p.topic):
            if port.topic in seen:
                continue
            seen.add(port.topic)
            codec = _codec(port)
            size = (
                Ring.nbytes(OUTPUT_RING_RECORDS, _LEN + codec.max_size)
                if direction == "output"
                else Mailbox.nbytes(codec.max_size)
            )
            size = (size + 63) // 64 * 64
            out.append(
                MappedPort(
                    direction, port.topic, type_name(port.type), codec.kind, codec.max_size,
                    offset, size,
                    deadline=deadlines.get(port.topic, 0.0) if direction == "input" else 0.0,
                )
            )
            offset += size
    return out


class MailboxFanOut:
    """A mapped input that several lanes read: the bridge's one subscription writes
    each message into every lane's mailbox."""

    def __init__(self, boxes: list[Mailbox]) -> None:
        self.boxes = boxes
        self.size = min(b.size for b in boxes)

    def write(self, payload: bytes) -> None:
        for box in self.boxes:
            box.write(payload)


def segment_size(ports: list[MappedPort]) -> int:
    return max(64, sum(p.nbytes for p in ports))


def create_channel(view: memoryview, port: MappedPort) -> Ring | Mailbox:
    """The supervisor's side: the channel of one mapped port, laid out in ``view``."""
    if port.direction in (REQUESTS, EVENTS):
        return Ring.create(view, ring_shape(port.direction, 0)[0], port.max_size)
    if port.direction == "output":
        return Ring.create(view, OUTPUT_RING_RECORDS, _LEN + port.max_size)
    return Mailbox.create(view, port.max_size)


def _codec(port: Port[Any]) -> Codec:
    codec = codec_for(port.type)
    if codec is None:
        raise ConfigurationError(
            f"port {port.qualified_name} ({port.topic}) is mapped to the middleware "
            f"(ros_mapping_whitelist), but its type {port.type.__name__} cannot cross: use "
            "float, int, bool, str, a 1-D float numpy array or a ROS message class, or "
            "leave the topic out of the whitelist"
        )
    return codec


class Tap:
    """Encodes a written value into an output ring (worker side)."""

    __slots__ = ("_data", "_encode", "_max", "_pushed", "_ring", "_words", "oversize")

    def __init__(self, ring: Ring, codec: Codec, pushed: list[int]) -> None:
        self._ring = ring
        self._pushed = pushed  # one flag shared by a run's taps: set after a push
        self._data = ring.data
        self._words = ring.data.cast("q")
        self._encode = codec.encode
        self._max = ring.record_size - _LEN
        self.oversize = 0

    def __call__(self, value: Any) -> None:
        data = self._encode(value)
        n = len(data)
        if n > self._max:
            self.oversize += 1
            return
        off = self._ring.reserve()
        if off < 0:
            return  # the ring counts the drop
        self._words[off >> 3] = n
        self._data[off + _LEN : off + _LEN + n] = data
        self._ring.commit()
        self._pushed[0] = 1

    def release(self) -> None:
        self._words.release()
        self._ring.close()


class Feeder:
    """Copies the newest message of a mailbox into the slots of the inputs it feeds,
    and counts the messages that a newer one replaced before an iteration read them
    (a mapped input holds the latest value: that is its meaning, not a fault)."""

    __slots__ = ("_box", "_buf", "_decode", "_seen", "read", "record", "slots",
                 "superseded", "topic", "type")

    def __init__(
        self, box: Mailbox, codec: Codec, slots: list[Slot], topic: str = "", type_: type = float
    ) -> None:
        self._box = box
        self._buf = bytearray(box.size)
        self._decode = codec.decode_buffer()
        # the write count of the value the slots hold: none of this run's (a message
        # that arrived before the worker set up its run is read, not skipped)
        self._seen = 0
        self.read = 0  # messages the loop read
        self.superseded = 0  # messages a newer one replaced before the loop read them
        self.slots = slots
        self.topic = topic
        self.type = type_
        self.record: Callable[[Any], None] | None = None  # a recording's tap, if recorded

    def __call__(self) -> None:
        box = self._box
        if box.version == self._seen:
            return
        n = box.try_read_into(self._buf)
        if n < 0:  # changed during the copy: the next iteration takes it
            return
        stamp = box.stamp  # the write count of the value read (newer than the version
        if stamp == self._seen:  # read above, if a write completed meanwhile)
            return
        self.superseded += stamp - self._seen - 1
        self._seen = stamp
        self.read += 1
        value = self._decode(self._buf, n)
        for slot in self.slots:
            slot.value = value
            slot.seq += 1
        if self.record is not None:
            self.record(value)

    def release(self) -> None:
        self._box.close()


class WorkerPorts:
    """The worker's end of a run's port channels: taps installed, feeders ready."""

    def __init__(
        self,
        buf: memoryview,
        ports: list[MappedPort],
        outputs: list[OutputPort[Any]],
        inputs: list[InputPort[Any]],
        *,
        actions: Sequence[ActionServer] = (),
        doorbell: Doorbell | None = None,
    ) -> None:
        self.taps: dict[str, Tap] = {}
        self._pushed = [0]  # set by a tap that pushed a record since the last ring
        self._bell = doorbell.ring if doorbell is not None else None
        self.feeders: list[Any] = []  # Feeder, and a ring's gate per mapped action
        self.action_taps: dict[str, EventTap] = {}
        self._rings: list[Ring] = []
        self._tapped: list[OutputPort[Any]] = []
        by_topic_action = {p.topic: s for s in actions for p in (s._requests, s._events)}
        by_topic_in: dict[str, list[InputPort[Any]]] = {}
        for port in inputs:
            by_topic_in.setdefault(port.topic, []).append(port)
        by_topic_out: dict[str, list[OutputPort[Any]]] = {}
        for writer in outputs:  # several with a fallback (it writes its primary's topics)
            by_topic_out.setdefault(writer.topic, []).append(writer)
        for mp in ports:
            view = buf[mp.offset : mp.offset + mp.nbytes]
            if mp.direction in (REQUESTS, EVENTS):
                self._action(Ring.open(view), mp.direction, by_topic_action[mp.topic])
            elif mp.direction == "output":
                writers = by_topic_out[mp.topic]
                tap = Tap(Ring.open(view), _codec(writers[0]), self._pushed)
                self.taps[mp.topic] = tap
                for out in writers:  # its write calls the tap, after the slot's store
                    out._tap = tap
                    self._tapped.append(out)
            else:
                readers = by_topic_in[mp.topic]
                slots = [p._slot for p in readers]
                self.feeders.append(
                    Feeder(Mailbox.open(view), _codec(readers[0]), slots, mp.topic,
                           readers[0].type)
                )
            view.release()

    def _action(self, ring: Ring, direction: str, server: ActionServer) -> None:
        codecs = message_codecs(server.name, server.type)
        if direction == REQUESTS:  # the ring's gate: one compare while nothing waits
            gate = ring.when_pending(RequestFeeder(ring, server._requests, codecs["Goal"]))
            self.feeders.append(gate)
        else:
            tap = EventTap(ring, codecs, self._pushed)
            self.action_taps[server.name] = tap
            server._events._tap = tap
            self._tapped.append(server._events)
        self._rings.append(ring)

    def ring_if_pushed(self) -> None:
        """After an iteration (outside its measured time): wake the supervisor once if
        any output pushed a record; it drains every ring when it wakes."""
        if self._pushed[0]:
            self._pushed[0] = 0
            if self._bell is not None:
                self._bell()

    def counts(self) -> dict[str, int]:
        """Messages each output (or action) could not hand over because they were too
        large."""
        counts = {topic: tap.oversize for topic, tap in self.taps.items() if tap.oversize}
        counts.update((n, t.oversize) for n, t in self.action_taps.items() if t.oversize)
        return counts

    def inputs(self) -> dict[str, dict[str, int]]:
        """Per mapped input: the messages the loop read, and those a newer one
        replaced before an iteration read them."""
        return {f.topic: {"read": f.read, "superseded": f.superseded}
                for f in self.feeders if isinstance(f, Feeder)}

    def release(self) -> None:
        for port in self._tapped:
            port._tap = None
        for tap in self.taps.values():
            tap.release()
        for feeder in self.feeders:
            feeder.release()  # a gate's first: it lets go of its ring's words
        for ring in self._rings:
            ring.close()


def read_record(ring: Ring, slot: int) -> bytes:
    """Supervisor side: the payload of one output record."""
    off = slot * ring.record_size
    n = int.from_bytes(ring.data[off : off + _LEN], "little", signed=True)
    return bytes(ring.data[off + _LEN : off + _LEN + n])
