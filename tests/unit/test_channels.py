"""Channels in one process: rings and mailboxes, in a bytearray or a Segment."""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator

import pytest

from rtcf._core._rings import Mailbox, Ring
from rtcf._runtime._shm import Segment


def _ring(capacity: int, record_size: int = 8) -> Ring:
    return Ring.create(bytearray(Ring.nbytes(capacity, record_size)), capacity, record_size)


def _rec(n: int) -> bytes:
    return struct.pack("q", n)


@pytest.fixture
def segment() -> Iterator[Segment]:
    seg = Segment.create(4096)
    try:
        yield seg
    finally:
        seg.close()


# -- Ring --------------------------------------------------------------------


def test_ring_push_pop_in_order() -> None:
    ring = _ring(8)
    assert ring.pop() is None and len(ring) == 0
    for i in range(5):
        assert ring.push(_rec(i))
    assert len(ring) == 5 and ring.produced == 5
    assert [ring.pop() for _ in range(5)] == [_rec(i) for i in range(5)]
    assert ring.pop() is None
    assert ring.dropped == 0


def test_full_ring_drops_and_counts_every_refused_record() -> None:
    ring = _ring(4)
    assert [ring.push(_rec(i)) for i in range(7)] == [True] * 4 + [False] * 3
    assert ring.dropped == 3 and ring.produced == 4 and len(ring) == 4
    assert ring.reserve() == -1
    assert ring.dropped == 4
    assert ring.pop() == _rec(0)
    assert ring.push(_rec(100))
    assert not ring.push(_rec(101))
    assert ring.dropped == 5
    assert [ring.pop() for _ in range(4)] == [_rec(1), _rec(2), _rec(3), _rec(100)]


def test_short_record_leaves_the_rest_of_the_slot_alone() -> None:
    ring = _ring(1, 16)
    assert ring.push(b"\xff" * 16)
    assert ring.pop() == b"\xff" * 16
    assert ring.push(b"ab")
    assert ring.pop() == b"ab" + b"\xff" * 14
    with pytest.raises(ValueError, match=r"17 bytes .* 16-byte records"):
        ring.push(bytes(17))


def test_push_accepts_any_contiguous_buffer() -> None:
    ring = _ring(4, 16)
    with memoryview(bytearray(struct.pack("2q", 7, 8))) as mv, mv.cast("q") as words:
        assert ring.push(words)
    assert ring.pop() == struct.pack("2q", 7, 8)


def test_pending_and_release_across_the_wrap() -> None:
    ring = _ring(8)
    for i in range(6):
        ring.push(_rec(i))
    for _ in range(6):
        ring.pop()
    for i in range(6, 12):  # slots 6, 7, then 0..3
        assert ring.push(_rec(i))
    assert ring.pending() == (6, 2)
    words = ring.data.cast("q")
    try:
        assert [words[6], words[7]] == [6, 7]
        ring.release(2)
        assert ring.pending() == (0, 4)
        assert list(words[0:4]) == [8, 9, 10, 11]
        with pytest.raises(ValueError, match="cannot release 5 records: 4 are waiting"):
            ring.release(5)
        ring.release(4)
        slot, n = ring.pending()
        assert (slot, n) == (4, 0)
        assert len(ring) == 0
    finally:
        words.release()


def test_reserve_commit_with_int64_words() -> None:
    ring = _ring(4, 24)
    assert ring.record_size == 24
    words = ring.data.cast("q")
    try:
        for seq in range(3):
            offset = ring.reserve()
            assert offset == seq * 24
            assert len(ring) == seq  # invisible until committed
            i = offset // 8
            words[i], words[i + 1], words[i + 2] = seq, -seq, seq * 1000
            ring.commit()
        assert len(ring) == 3
        assert ring.pop() == struct.pack("3q", 0, 0, 0)
        assert ring.pop() == struct.pack("3q", 1, -1, 1000)
        out = bytearray(24)
        assert ring.pop_into(out)
        assert struct.unpack("3q", out) == (2, -2, 2000)
        assert not ring.pop_into(out)
        with pytest.raises(ValueError, match="8 bytes, records have 24"):
            ring.pop_into(bytearray(8))
    finally:
        words.release()


def test_commit_without_reserve_is_an_error() -> None:
    ring = _ring(1)
    with pytest.raises(RuntimeError, match="without a successful reserve"):
        ring.commit()
    assert ring.reserve() == 0
    ring.commit()
    assert ring.reserve() == -1
    with pytest.raises(RuntimeError):
        ring.commit()
    assert ring.produced == 1 and ring.dropped == 1


@pytest.mark.parametrize(
    ("capacity", "record_size", "shape"),
    [(1, 1, (1, 8)), (3, 8, (4, 8)), (1000, 33, (1024, 40)), (1024, 64, (1024, 64))],
)
def test_capacity_power_of_two_record_size_multiple_of_8(
    capacity: int, record_size: int, shape: tuple[int, int]
) -> None:
    ring = _ring(capacity, record_size)
    assert (ring.capacity, ring.record_size) == shape
    assert len(ring.data) == shape[0] * shape[1]
    assert Ring.nbytes(capacity, record_size) == Ring.nbytes(*shape) > shape[0] * shape[1]
    with pytest.raises(ValueError):
        Ring.nbytes(0, 8)


def test_data_is_64_byte_aligned_in_the_buffer(segment: Segment) -> None:
    ring = Ring.create(segment.buf[64:], 4, 8)
    with ring:
        ring.push(_rec(0x1122))
        offset = Ring.nbytes(4, 8) - 4 * 8
        assert offset % 64 == 0
        assert segment.buf[64 + offset : 64 + offset + 8] == _rec(0x1122)


def test_open_sees_the_same_ring() -> None:
    buf = bytearray(Ring.nbytes(4, 16) + 100)
    producer = Ring.create(buf, 4, 16)
    for i in range(6):
        producer.push(_rec(i))
    consumer = Ring.open(buf)
    assert (consumer.capacity, consumer.record_size) == (4, 16)
    assert len(consumer) == 4 and consumer.dropped == 2 and consumer.produced == 4
    assert consumer.pop() == _rec(0) + bytes(8)
    assert len(producer) == 3
    assert producer.push(_rec(9))
    assert [consumer.pop() for _ in range(4)] == [_rec(i) + bytes(8) for i in (1, 2, 3, 9)]


def test_open_on_garbage_raises() -> None:
    with pytest.raises(ValueError, match="does not hold an rtcf ring"):
        Ring.open(bytearray(b"\x01" * 4096))
    with pytest.raises(ValueError, match="too small"):
        Ring.open(bytearray(16))
    with pytest.raises(ValueError, match="writable"):
        Ring.open(bytes(4096))
    with pytest.raises(ValueError, match="too small for a ring"):
        Ring.create(bytearray(100), 4, 8)
    buf = bytearray(Ring.nbytes(4, 8))
    Ring.create(buf, 4, 8).close()
    with pytest.raises(ValueError, match="does not hold an rtcf mailbox"):
        Mailbox.open(buf)


def test_unaligned_buffer_is_refused() -> None:
    buf = bytearray(Ring.nbytes(4, 8) + 8)
    with memoryview(buf) as mv, pytest.raises(ValueError, match="8-byte boundary"):
        Ring.create(mv[3:], 4, 8)


# -- Mailbox -----------------------------------------------------------------


def test_mailbox_never_written() -> None:
    box = Mailbox.create(bytearray(Mailbox.nbytes(16)), 16)
    out = bytearray(16)
    assert box.try_read_into(out) == -1
    assert box.read() is None
    assert box.version == 0


def test_mailbox_round_trip_and_version() -> None:
    buf = bytearray(Mailbox.nbytes(100))
    writer = Mailbox.create(buf, 100)
    reader = Mailbox.open(buf)
    assert reader.size == 100
    for i in range(1, 6):
        writer.write(b"value %d" % i)
        assert reader.version == i
        assert reader.read() == b"value %d" % i
    writer.write(b"")
    assert reader.read() == b""
    writer.write(bytes(range(100)))
    out = bytearray(128)
    assert reader.try_read_into(out) == 100
    assert out[:100] == bytes(range(100))
    assert reader.version == 7
    writer.write(struct.pack("2q", 3, 4))
    words = bytearray(16)
    with memoryview(words) as mv, mv.cast("q") as as_words:
        assert reader.try_read_into(as_words) == 16
        assert list(as_words) == [3, 4]
    with pytest.raises(ValueError, match="4 bytes, the value has 16"):
        reader.try_read_into(bytearray(4))


def test_mailbox_payload_too_big() -> None:
    box = Mailbox.create(bytearray(Mailbox.nbytes(8)), 8)
    with pytest.raises(ValueError, match="9 bytes exceeds its size of 8 bytes"):
        box.write(bytes(9))
    assert box.version == 0


def test_mailbox_reader_never_waits_for_the_writer() -> None:
    box = Mailbox.create(bytearray(Mailbox.nbytes(8)), 8)
    box.write(_rec(1))
    out = bytearray(8)
    real = box._payload

    class Meddler(tuple[memoryview, ...]):
        """Stands for the payload views: the writer runs twice before the copy."""

        def __getitem__(self, b: int) -> memoryview:  # type: ignore[override]
            box._payload = real
            box.write(_rec(2))  # into the other buffer
            box.write(_rec(3))  # into the one being read
            return real[b]

    box._payload = Meddler(real)
    assert box.try_read_into(out) == -2
    assert box.try_read_into(out) == 8 and out == _rec(3)
    assert box.version == 3

    meta = box._meta[box._ctl[8]]  # the latest buffer's sequence word, as mid-write
    meta[0] += 1
    assert box.try_read_into(out) == -2
    with pytest.raises(RuntimeError, match="kept changing during 5 read attempts"):
        box.read(retries=5)
    meta[0] += 1
    assert box.read() == _rec(3)


# -- in a Segment ------------------------------------------------------------


def test_channels_in_a_segment_close_cleanly(segment: Segment) -> None:
    ring = Ring.create(segment.buf, 8, 8)
    box = Mailbox.create(segment.buf[1024:], 64)
    with pytest.raises(BufferError, match="views must be released first"):
        segment.close()
    assert not segment.closed
    segment.buf[2000] = 1  # still usable after the refused close
    ring.close()
    ring.close()
    box.close()
    assert repr(ring) == "<Ring closed>" and repr(box) == "<Mailbox closed>"
    segment.close()
    assert segment.closed


def test_refused_open_leaves_no_view_behind(segment: Segment) -> None:
    with pytest.raises(ValueError, match="does not hold an rtcf ring"):
        Ring.open(segment.buf)
    with pytest.raises(ValueError, match="does not hold an rtcf mailbox"):
        Mailbox.open(segment.buf[64:])
    with pytest.raises(ValueError, match="too small for a ring"):
        Ring.create(segment.buf, 1024, 64)
    segment.close()  # nothing still exports the mapping
    assert segment.closed


def test_mailbox_reader_never_goes_back_to_an_older_value() -> None:
    from rtcf._core._rings import _M_LATEST

    buf = bytearray(Mailbox.nbytes(8))
    box = Mailbox.create(buf, 8)
    out = bytearray(8)
    box.write((1).to_bytes(8, "little"))
    box.write((2).to_bytes(8, "little"))
    assert box.try_read_into(out) == 8 and int.from_bytes(out, "little") == 2
    # a 'latest' word loaded a moment too early points at the buffer of value 1
    ctl = memoryview(buf).cast("q")
    ctl[_M_LATEST] = 1 - ctl[_M_LATEST]
    assert box.try_read_into(out) == -2  # keep 2; never hand out 1 after 2
    assert int.from_bytes(out, "little") == 2
    ctl[_M_LATEST] = 1 - ctl[_M_LATEST]
    box.write((3).to_bytes(8, "little"))
    assert box.try_read_into(out) == 8 and int.from_bytes(out, "little") == 3
    ctl.release()
    box.close()


def test_push_words_commits_four_words_and_counts_a_full_ring() -> None:
    from rtcf._core._rings import Ring

    ring = Ring.create(bytearray(Ring.nbytes(2, 32)), 2, 32)
    words = ring.data.cast("q")
    floats = ring.data.cast("d")
    assert ring.push_words(words, floats, 8, 5, 500, 2.5)
    assert ring.push_words(words, words, 1, 6, 600, True)
    assert not ring.push_words(words, words, 8, 7, 700, 3)  # full
    assert ring.dropped == 1 and len(ring) == 2
    first = memoryview(ring.pop()).cast("q")
    assert first.tolist()[:3] == [8, 5, 500]
    assert memoryview(first.tobytes()[24:32]).cast("d")[0] == 2.5
    second = memoryview(ring.pop()).cast("q").tolist()
    assert second == [1, 6, 600, 1]
    words.release()
    floats.release()
    ring.close()


def test_push_all_commits_every_record_at_once_or_none() -> None:
    ring = _ring(4)
    consumer = Ring.open(ring._ctl.obj)
    assert ring.push(_rec(0))
    assert not ring.push_all([_rec(1), _rec(2), _rec(3), _rec(4)])  # 3 free: none goes
    assert ring.dropped == 1 and len(consumer) == 1
    assert ring.push_all([_rec(1), _rec(2), _rec(3)])
    assert [consumer.pop() for _ in range(5)] == [_rec(i) for i in range(4)] + [None]
    assert ring.push_all([_rec(5), _rec(6)])  # across the wrap
    assert [consumer.pop() for _ in range(2)] == [_rec(5), _rec(6)]
    with pytest.raises(ValueError, match="5 records do not fit"):
        ring.push_all([_rec(i) for i in range(5)])
    consumer.close()
    ring.close()


# -- Memory fences (weakly ordered CPUs) ----------------------------------------


def test_fences_are_on_exactly_where_the_cpu_needs_them() -> None:
    import os

    from rtcf._core import _atomics, _rings

    # the extension is built on install (setup.py); CI installs it everywhere
    _atomics.release_fence()
    _atomics.acquire_fence()
    forced = os.environ.get("RTCF_FENCES") == "1"
    assert _rings.FENCED == (forced or not _rings.TOTAL_STORE_ORDER)


class _FenceSpy:
    """Stands in for the fences and records what the channel's memory held at each one."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, snapshot: Callable[[], tuple]) -> None:
        from rtcf._core import _rings

        self.seen: list[tuple] = []
        monkeypatch.setattr(_rings, "FENCED", True)
        monkeypatch.setattr(_rings, "acquire_fence", lambda: self.seen.append(("acq", *snapshot())))
        monkeypatch.setattr(_rings, "release_fence", lambda: self.seen.append(("rel", *snapshot())))


@pytest.mark.parametrize("how", ["push", "reserve-commit", "push_words"])
def test_a_producer_fences_between_the_record_and_the_head(
    monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    from rtcf._core._rings import _R_HEAD

    buf = bytearray(Ring.nbytes(2, 32))
    ring = Ring.create(buf, 2, 32)
    ctl = memoryview(buf).cast("q")
    words = ring.data.cast("q")
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_R_HEAD], words[0]))
    if how == "push":
        ring.push(struct.pack("4q", 7, 7, 7, 7))
    elif how == "reserve-commit":
        words[ring.reserve() >> 3] = 7
        ring.commit()
    else:
        ring.push_words(words, words, 7, 7, 7, 7)
    # one release fence, with the record written and the head not yet moved
    assert spy.seen == [("rel", 0, 7)]
    assert ctl[_R_HEAD] == 1
    words.release()
    ctl.release()
    ring.close()


def test_push_all_fences_once_after_the_last_record_before_the_head(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rtcf._core._rings import _R_HEAD

    buf = bytearray(Ring.nbytes(4, 8))
    ring = Ring.create(buf, 4, 8)
    ctl = memoryview(buf).cast("q")
    words = ring.data.cast("q")
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_R_HEAD], words.tolist()[:3]))
    assert ring.push_all([_rec(5), _rec(6), _rec(7)])
    assert spy.seen == [("rel", 0, [5, 6, 7])] and ctl[_R_HEAD] == 3
    words.release()
    ctl.release()
    ring.close()


def test_a_producer_fences_after_reading_the_tail_of_a_full_looking_ring(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rtcf._core._rings import _R_TAIL

    ring = _ring(2)
    consumer = Ring.open(ring._ctl.obj)  # the same buffer, the other side
    ring.push(_rec(1))
    ring.push(_rec(2))
    assert consumer.pop() == _rec(1)  # frees a slot the producer has not seen free yet
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_R_TAIL],))
    assert ring.push(_rec(3))
    # the tail is read, then an acquire fence, then the slot written, then a release
    assert spy.seen == [("acq", 1), ("rel", 1)]
    consumer.close()
    ring.close()


@pytest.mark.parametrize("how", ["pop", "pop_into", "pending-release"])
def test_a_consumer_fences_after_the_head_and_before_the_tail(
    monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    from rtcf._core._rings import _R_TAIL

    ring = _ring(4)
    ring.push(_rec(5))
    out = bytearray(8)
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_R_TAIL], bytes(out)))
    if how == "pop":
        assert ring.pop() == _rec(5)
        out[:] = _rec(5)  # pop copies internally; its two fences are what is checked
        assert [s[:2] for s in spy.seen] == [("acq", 0), ("rel", 0)]
    elif how == "pop_into":
        assert ring.pop_into(out)
        # acquire before the copy, release after it and before the tail moves
        assert spy.seen == [("acq", 0, bytes(8)), ("rel", 0, _rec(5))]
    else:
        slot, n = ring.pending()
        out[:] = ring.data[slot * 8 : slot * 8 + 8]
        ring.release(n)
        assert spy.seen == [("acq", 0, bytes(8)), ("rel", 0, _rec(5))]
    assert ctl[_R_TAIL] == 1
    ring.close()


def test_a_mailbox_writer_fences_around_the_payload_and_before_latest(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rtcf._core._rings import _M_LATEST

    box = Mailbox.create(bytearray(Mailbox.nbytes(8)), 8)
    box.write(_rec(1))  # into buffer 1, now latest: the next write goes to buffer 0
    meta, payload, ctl = box._meta[0], box._payload[0], box._ctl
    spy = _FenceSpy(monkeypatch, lambda: (meta[0], bytes(payload), ctl[_M_LATEST]))
    box.write(_rec(2))
    assert spy.seen == [
        ("rel", 1, bytes(8), 1),  # odd sequence before any payload
        ("rel", 1, _rec(2), 1),  # payload before the even sequence
        ("rel", 2, _rec(2), 1),  # even sequence before 'latest' points here
    ]
    assert ctl[_M_LATEST] == 0
    box.close()


def test_a_mailbox_reader_fences_between_its_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    box = Mailbox.create(bytearray(Mailbox.nbytes(8)), 8)
    box.write(_rec(9))
    out = bytearray(8)
    spy = _FenceSpy(monkeypatch, lambda: (bytes(out),))
    assert box.try_read_into(out) == 8
    # after 'latest', after the sequence (payload not yet copied), after the copy
    assert spy.seen == [("acq", bytes(8)), ("acq", bytes(8)), ("acq", _rec(9))]
    box.close()
