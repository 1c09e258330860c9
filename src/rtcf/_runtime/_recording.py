"""Recording every port at full loop rate: the worker's taps and the supervisor's drain.

Each recorded topic gets a ring in one shared segment. A float, int or bool topic: a
ring of fixed-size records (payload length, the iteration, its stamp: ROS time of the
scheduled start, ns; then the value in one word). A topic whose values vary in size (a
string, a float array, a ROS message): a ring of variable-length records
(:class:`rtcf._core._byte_rings.ByteRing`: a record takes what its value needs, 48
bytes for three floats, not the type's worst case of 64 KiB), each the iteration, its
stamp, then the value's bytes in the topic's codec (:mod:`rtcf._runtime._codec`: float
arrays packed as they are, ROS messages as their serialized bytes; nothing is
pickled). An output is recorded at every ``write`` (a tap, as for a mapped port); an
input fed from the middleware when its feeder brings a new message. A record that
finds its ring full is dropped and counted by the ring, on the real-time clock; on a
simulated clock the loop waits for room instead, since time does not matter there and
nothing should be lost. The supervisor drains the rings into a writer
(:mod:`rtcf._runtime._mcap`).
"""

from __future__ import annotations

import dataclasses
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from .._core._action_protocol import ActionEvent, ActionRequest
from .._core._byte_rings import ByteRing, record_bytes
from .._core._errors import ConfigurationError
from .._core._loop_state import LoopState
from .._core._message_types import type_name
from .._core._ports import InputPort, OutputPort
from .._core._rings import Ring
from ._codec import Codec, codec_for
from ._port_channels import Feeder

_HDR = 24  # a word ring's record: payload length, iteration, stamp: three int64
_STAMP = 16  # a byte ring's record: iteration, stamp, then the value's bytes
_WORD_KINDS = ("float", "int", "bool")  # one word each: rings of fixed-size records
_BUDGET = 4 << 20  # bytes of ring per recorded topic at most
_MAX_RECORDS = 1 << 14  # 8 s at 2 kHz


@dataclass(frozen=True)
class RecordedTopic:
    """One recorded topic, as both processes see it."""

    topic: str
    direction: str  # "output" (written in the loop) or "input" (fed from the middleware)
    type_name: str
    kind: str  # the codec
    max_size: int
    capacity: int  # records of a ring of fixed-size records; bytes of a byte ring
    offset: int = 0
    nbytes: int = 0

    @property
    def byte_ring(self) -> bool:
        """Whether the topic's values vary in size: a ByteRing of variable-length records."""
        return self.kind not in _WORD_KINDS


def topic_pattern(pattern: str, option: str) -> re.Pattern[str]:
    """``pattern`` compiled, or an error naming the command line's ``option`` that gave it."""
    try:
        return re.compile(pattern)
    except re.error as exc:
        raise ConfigurationError(
            f"{option} {pattern!r} is not a valid regular expression: {exc}"
        ) from None


def recorded_topics(
    outputs: Iterable[OutputPort[Any]], fed_inputs: Iterable[InputPort[Any]], pattern: str
) -> list[RecordedTopic]:
    """The topics to record (full match of ``pattern``), laid out in one segment."""
    regex = topic_pattern(pattern, "--record-topics")
    out: list[RecordedTopic] = []
    seen: set[str] = set()
    offset = 0
    for direction, ports in (("output", outputs), ("input", fed_inputs)):
        for port in sorted(ports, key=lambda p: p.topic):
            if port.topic in seen or not regex.fullmatch(port.topic):
                continue
            if port.type is ActionEvent or port.type is ActionRequest:
                continue  # an action's two ports: its messages are not recorded (yet)
            seen.add(port.topic)
            codec = codec_for(port.type)
            if codec is None:
                raise ConfigurationError(
                    f"port {port.qualified_name} ({port.topic}) is recorded, but its type "
                    f"{port.type.__name__} cannot be: record float, int, bool, str, 1-D "
                    "float numpy arrays or ROS messages, or leave the topic out with "
                    "--record-topics"
                )
            if codec.kind in _WORD_KINDS:
                size = _HDR + codec.max_size
                capacity = 64
                while capacity * 2 <= _MAX_RECORDS and Ring.nbytes(capacity * 2, size) <= _BUDGET:
                    capacity *= 2
                nbytes = Ring.nbytes(capacity, size)
            else:  # as many records as the values need, of the same budget
                capacity = _BUDGET
                if 2 * record_bytes(_STAMP + codec.max_size) > capacity:
                    raise ConfigurationError(
                        f"port {port.qualified_name} ({port.topic}) is recorded, but its "
                        f"values of up to {codec.max_size} bytes do not fit the recording's "
                        f"ring of {capacity} bytes"
                    )
                nbytes = ByteRing.nbytes(capacity)
            nbytes = (nbytes + 63) // 64 * 64
            out.append(
                RecordedTopic(
                    port.topic, direction, type_name(port.type), codec.kind, codec.max_size,
                    capacity, offset, nbytes,
                )
            )
            offset += nbytes
    return out


def relaid(topics: list[RecordedTopic]) -> list[RecordedTopic]:
    """The same topics laid out one after the other again (some were left out)."""
    out: list[RecordedTopic] = []
    offset = 0
    for t in topics:
        out.append(dataclasses.replace(t, offset=offset))
        offset += t.nbytes
    return out


def segment_size(topics: list[RecordedTopic]) -> int:
    return max(64, sum(t.nbytes for t in topics))


class RecordTap:
    """Encodes a value with its iteration and stamp into a topic's byte ring (worker
    side): a record of the value's own size."""

    __slots__ = ("_encode", "_max", "_ring", "_state", "_wait", "call", "oversize")

    def __init__(self, ring: ByteRing, codec: Codec, state: LoopState, wait: bool) -> None:
        # what a recorded port's write calls with each value: this, or the same compiled
        self.call: Callable[[Any], None] = self
        self._ring = ring
        self._encode = codec.encode
        self._max = codec.max_size  # what a channel of the type takes (a replay feeds it)
        self._state = state
        self._wait = wait  # simulated clock: wait for room rather than drop
        self.oversize = 0

    def __call__(self, value: Any) -> None:
        data = self._encode(value)
        n = len(data)
        if n > self._max:
            self.oversize += 1
            return
        if self._wait:
            self._wait_for_room(n)
        state = self._state
        # a full ring counts the drop
        self._ring.push_stamped(state.iteration, state.stamp_ns, data)

    def _wait_for_room(self, n: int) -> None:
        """A simulated clock: wait for the supervisor (10 s at most: it may be gone)."""
        ring = self._ring
        give_up = time.monotonic() + 10.0
        while not ring.fits(_STAMP + n) and time.monotonic() < give_up:
            time.sleep(0.0005)

    @property
    def dropped(self) -> int:
        return self._ring.dropped

    def release(self) -> None:
        self._ring.close()


class _WordRecordTap:
    """A float, int or bool: stored as one word of a fixed-size record, with no bytes
    made.

    The hot path of a recording: one call that stores four words and commits."""

    __slots__ = ("_n", "_ring", "_state", "_values", "_wait", "_words", "call")

    oversize = 0  # a word always fits

    def __init__(self, ring: Ring, codec: Codec, state: LoopState, wait: bool) -> None:
        self.call: Callable[[Any], None] = self
        self._ring = ring
        self._state = state
        self._wait = wait  # simulated clock: wait for room rather than drop
        self._words = ring.data.cast("q")
        self._values = ring.data.cast("d") if codec.kind == "float" else self._words
        self._n = 1 if codec.kind == "bool" else 8  # little-endian: the first byte is it
        # the same push, compiled, for the port's write to call (not on a simulated
        # clock, which waits for room rather than drop)
        compiled = None if wait else ring.word_tap(state, codec.kind)
        if compiled is not None:
            self.call = compiled

    def __call__(self, value: Any) -> None:
        if self._wait:
            self._wait_for_room()
        state = self._state
        # a full ring counts the drop
        self._ring.push_words(
            self._words, self._values, self._n, state.iteration, state.stamp_ns, value
        )

    def _wait_for_room(self) -> None:
        """A simulated clock: wait for the supervisor (10 s at most: it may be gone)."""
        ring = self._ring
        if len(ring) < ring.capacity:
            return
        give_up = time.monotonic() + 10.0
        while len(ring) >= ring.capacity and time.monotonic() < give_up:
            time.sleep(0.0005)

    @property
    def dropped(self) -> int:
        return self._ring.dropped

    def release(self) -> None:
        if self.call is not self:
            self.call.release()  # type: ignore[attr-defined]
        if self._values is not self._words:
            self._values.release()
        self._words.release()
        self._ring.close()


def make_tap(
    view: memoryview, codec: Codec, state: LoopState, wait: bool
) -> RecordTap | _WordRecordTap:
    """The tap of a topic, on its ring in ``view``: words for float, int and bool;
    encoded bytes for the rest."""
    if codec.kind in _WORD_KINDS:
        return _WordRecordTap(Ring.open(view), codec, state, wait)
    return RecordTap(ByteRing.open(view), codec, state, wait)


class _Both:
    """A mapped and recorded output: the middleware's tap, then the recorder's."""

    __slots__ = ("first", "second")

    def __init__(self, first: Callable[[Any], None], second: Callable[[Any], None]) -> None:
        self.first = first
        self.second = second

    def __call__(self, value: Any) -> None:
        self.first(value)
        self.second(value)


class WorkerRecording:
    """The worker's end of a recording: taps on the recorded outputs and feeders."""

    def __init__(
        self,
        buf: memoryview,
        topics: list[RecordedTopic],
        outputs: Iterable[OutputPort[Any]],
        feeders: Iterable[Feeder],
        state: LoopState,
        *,
        wait: bool,
    ) -> None:
        self.taps: dict[str, RecordTap | _WordRecordTap] = {}
        self._restore: list[tuple[OutputPort[Any], Any]] = []
        self._feeders: list[Feeder] = []
        writers: dict[str, list[OutputPort[Any]]] = {}
        for port in outputs:
            writers.setdefault(port.topic, []).append(port)
        # a mapped action's requests come in through its ring's gate, which feeds no
        # topic (and is not recorded): only the feeders of a topic (the mapped inputs',
        # a replay's) are
        fed = {f.topic: f for f in feeders if getattr(f, "topic", None) is not None}
        for t in topics:
            codec = codec_for(_port_type(writers, fed, t))
            assert codec is not None
            with buf[t.offset : t.offset + t.nbytes] as view:
                tap = make_tap(view, codec, state, wait)
            self.taps[t.topic] = tap
            if t.direction == "output":
                for port in writers[t.topic]:
                    self._restore.append((port, port._tap))
                    port._tap = tap.call if port._tap is None else _Both(port._tap, tap.call)
            else:
                feeder = fed[t.topic]
                feeder.record = tap.call
                self._feeders.append(feeder)

    def counts(self) -> dict[str, dict[str, int]]:
        """Records each topic dropped (ring full) or could not take (too large)."""
        return {
            topic: {"dropped": tap.dropped, "oversize": tap.oversize}
            for topic, tap in self.taps.items()
            if tap.dropped or tap.oversize
        }

    def release(self) -> None:
        for port, tap in reversed(self._restore):
            port._tap = tap
        for feeder in self._feeders:
            feeder.record = None
        for tap in self.taps.values():
            tap.release()


def _port_type(
    writers: dict[str, list[OutputPort[Any]]], fed: dict[str, Feeder], t: RecordedTopic
) -> type:
    if t.direction == "output":
        return writers[t.topic][0].type
    return fed[t.topic].type


class RecordSink(Protocol):
    """Where a run's records go: a file (McapRecording), a live view, or both."""

    pattern: str  # the topics to record, a full-match regex

    def begin(self, topics: list[RecordedTopic]) -> None: ...

    def write(self, record: Record) -> None: ...

    def end_run(self, dropped: dict[str, int], counts: dict[str, dict[str, int]]) -> None: ...


@dataclass
class Record:
    """One recorded value as the supervisor reads it."""

    topic: str
    iteration: int
    stamp_ns: int
    payload: bytes


class RecordingDrain:
    """The supervisor's end: the rings of a run, drained in order of arrival per topic."""

    def __init__(self, buf: memoryview, topics: list[RecordedTopic]) -> None:
        self.topics = topics
        self.rings: list[tuple[RecordedTopic, Ring | ByteRing]] = []
        for t in topics:
            with buf[t.offset : t.offset + t.nbytes] as view:
                if t.byte_ring:
                    self.rings.append((t, ByteRing.create(view, t.capacity)))
                else:
                    self.rings.append((t, Ring.create(view, t.capacity, _HDR + t.max_size)))

    def drain(self, sink: Callable[[Record], None], limit: int = 1 << 62) -> int:
        """Hand the waiting records to ``sink``, at most ``limit`` of each topic (a
        supervisor that fell behind must still beat its heartbeat between drains: a byte
        ring's backlog can be 87,000 records); return how many."""
        total = 0
        for t, ring in self.rings:
            if isinstance(ring, ByteRing):
                total += _drain_bytes(t.topic, ring, sink, limit)
            else:
                total += _drain_words(t.topic, ring, sink, limit)
        return total

    def dropped(self) -> dict[str, int]:
        return {t.topic: ring.dropped for t, ring in self.rings if ring.dropped}

    def close(self) -> None:
        for _, ring in self.rings:
            ring.close()


def _drain_words(topic: str, ring: Ring, sink: Callable[[Record], None], limit: int) -> int:
    total = 0
    while True:
        start, n = ring.pending()
        n = min(n, limit - total)
        if n <= 0:
            return total
        size = ring.record_size
        data = ring.data
        for k in range(n):
            off = (start + k) * size
            head = data[off : off + _HDR].cast("q")
            length, iteration, stamp = head[0], head[1], head[2]
            head.release()
            payload = bytes(data[off + _HDR : off + _HDR + length])
            sink(Record(topic, iteration, stamp, payload))
        ring.release(n)
        total += n


_RELEASE_EVERY = 256  # records: a long backlog gives the producer room as it goes


def _drain_bytes(topic: str, ring: ByteRing, sink: Callable[[Record], None], limit: int) -> int:
    position, head = ring.pending()
    if position == head:
        return 0
    data, words, record_at = ring.data, ring.words, ring.record_at
    total = 0
    while position < head and total < limit:
        off, n, position = record_at(position)
        w = off >> 3
        sink(Record(topic, words[w], words[w + 1], bytes(data[off + _STAMP : off + n])))
        total += 1
        if not total % _RELEASE_EVERY:
            ring.release_to(position)
    ring.release_to(position)
    return total
