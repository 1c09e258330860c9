"""The ring of variable-length records in one process: wrap, full, exact fit, too large,
and where its fences fall (the cross-process tests are in
tests/integration/test_channels_processes.py)."""

from __future__ import annotations

import struct
from collections.abc import Callable

import pytest

from rtcf._core._byte_rings import _B_HEAD, _B_TAIL, ByteRing, record_bytes


def _ring(size: int = 256) -> ByteRing:
    return ByteRing.create(bytearray(ByteRing.nbytes(size)), size)


def _drain(ring: ByteRing) -> list[bytes]:
    out = []
    while (record := ring.pop()) is not None:
        out.append(record)
    return out


def test_records_of_any_length_come_back_in_order_and_intact() -> None:
    ring = _ring()
    records = [b"", b"a", b"1234567", b"12345678", b"123456789", bytes(range(40))]
    assert all(ring.push(r) for r in records)
    # each takes its length word and itself padded to 8
    assert len(ring) == sum(record_bytes(len(r)) for r in records) == 8 * 6 + 80
    assert _drain(ring) == records
    assert len(ring) == 0 and ring.dropped == 0
    ring.close()


def test_a_ring_holds_as_many_records_as_their_bytes() -> None:
    ring = _ring(4096)
    three_floats = struct.pack("3d", 1.0, 2.0, 3.0)  # 24 bytes: 32 with the length
    n = 0
    while ring.push(three_floats):
        n += 1
    assert n == 4096 // 32 and ring.dropped == 1
    ring.close()


def test_a_record_that_does_not_fit_before_the_end_wraps_to_the_start() -> None:
    ring = _ring(128)
    assert ring.push(bytes(40))  # 48 bytes: 0..48
    assert ring.push(bytes(40))  # 48..96
    assert ring.pop() == bytes(40)  # frees 0..48
    # 32 bytes are left before the end: a record of 48 goes to the start, behind a wrap
    # marker, and the skipped bytes count as used until the consumer passes them
    assert ring.push(b"w" * 40)
    assert len(ring) == 48 + 32 + 48
    assert ring.words[96 >> 3] == -1 and ring.words[0] == 40
    assert not ring.push(b"")  # 128 bytes used: even a bare length word is dropped
    assert ring.dropped == 1
    assert _drain(ring) == [bytes(40), b"w" * 40]
    tail, head = ring.pending()
    assert tail == head == 128 + 48
    ring.close()


def test_a_record_that_exactly_fills_the_rest_needs_no_marker() -> None:
    ring = _ring(128)
    assert ring.push(bytes(56))  # 64 bytes: 0..64
    assert ring.push(b"x" * 56)  # 64..128: ends at the end exactly
    assert not ring.push(b"")  # exactly full
    assert ring.dropped == 1
    assert ring.pop() == bytes(56)
    assert ring.push(b"y" * 56)  # at the start again, no marker
    assert ring.words[0] == 56
    assert _drain(ring) == [b"x" * 56, b"y" * 56]
    ring.close()


def test_a_full_ring_drops_and_counts_and_takes_records_again_when_drained() -> None:
    ring = _ring(64)
    assert ring.push(bytes(24)) and ring.push(bytes(16))  # 32 + 24 of 64 bytes
    assert not ring.push(bytes(8))  # needs 16, 8 free
    assert ring.push(b"")  # 8 bytes: fits exactly
    assert ring.dropped == 1
    assert len(_drain(ring)) == 3
    for k in range(100):  # around and around: every record fits once drained
        payload = bytes([k]) * (k % 24)
        assert ring.push(payload)
        assert ring.pop() == payload
    assert ring.dropped == 1
    ring.close()


def test_a_record_larger_than_half_the_ring_is_refused_at_once() -> None:
    ring = _ring(256)
    assert ring.max_record == 120
    assert ring.push(bytes(120))  # the largest that always fits once drained
    with pytest.raises(ValueError, match="record of 121 bytes does not fit a byte ring of 256"):
        ring.push(bytes(121))
    assert ring.dropped == 0  # refused, not dropped: the caller must not send it
    ring.close()


def test_reserve_commit_and_the_walk_of_pending_records() -> None:
    ring = _ring(128)
    at = ring.reserve(16)
    ring.words[at >> 3] = 7
    ring.words[(at >> 3) + 1] = 8
    assert ring.pending() == (0, 0)  # not committed: not seen
    ring.commit()
    assert ring.reserve(8) > 0
    ring.commit()
    position, head = ring.pending()
    got = []
    while position < head:
        off, n, position = ring.record_at(position)
        got.append((n, ring.words[off >> 3]))
    ring.release_to(position)
    assert got == [(16, 7), (8, 0)] and len(ring) == 0
    with pytest.raises(RuntimeError, match="without a successful reserve"):
        ring.commit()
    with pytest.raises(ValueError, match="cannot release to byte 999"):
        ring.release_to(999)
    ring.close()


def test_open_sees_the_same_ring_and_refuses_anything_else() -> None:
    buf = bytearray(ByteRing.nbytes(100))
    producer = ByteRing.create(buf, 100)
    assert producer.size == 128  # a power of two
    consumer = ByteRing.open(buf)
    assert producer.push(b"hello")
    assert consumer.pop() == b"hello"
    producer.close()
    consumer.close()
    with pytest.raises(ValueError, match="bad magic number"):
        ByteRing.open(bytearray(1024))
    with pytest.raises(ValueError, match="too small for a byte ring"):
        ByteRing.create(bytearray(100), 64)


def test_fits_says_whether_a_waiting_producer_may_write() -> None:
    ring = _ring(64)
    assert ring.fits(56) and not ring.fits(57 + 64)
    assert ring.push(bytes(24))
    assert ring.fits(24) and not ring.fits(25)
    ring.close()


def test_push_stamped_writes_two_words_then_the_bytes_and_wraps_and_drops_alike() -> None:
    ring = _ring(128)
    assert ring.push_stamped(7, -8, b"abc")  # 8 + 16 + 8: 32 bytes, 0..32
    assert ring.push_stamped(1, 2, bytes(40))  # 64 bytes: 32..96
    assert ring.pop() == struct.pack("2q", 7, -8) + b"abc"
    assert ring.push_stamped(9, 9, b"")  # 24 bytes: 96..120
    assert ring.push_stamped(3, 4, bytearray(b"x" * 5))  # 32: not in the 8 before the end
    assert ring.words[120 >> 3] == -1  # the marker; the record at the start
    assert ring.words[:3].tolist() == [21, 3, 4]
    assert not ring.push_stamped(5, 6, b"")  # 128 bytes used
    assert ring.dropped == 1
    assert _drain(ring) == [
        struct.pack("2q", 1, 2) + bytes(40), struct.pack("2q", 9, 9),
        struct.pack("2q", 3, 4) + b"x" * 5,
    ]
    with pytest.raises(ValueError, match="record of 57 bytes does not fit"):
        ring.push_stamped(0, 0, bytes(41))
    assert ring.push_stamped(0, 0, memoryview(bytes(40)))  # 64 bytes: the largest
    ring.close()


# -- Memory fences (weakly ordered CPUs): the same places as the Ring's ----------------


class _FenceSpy:
    """Stands in for the fences and records what the ring's memory held at each one."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, snapshot: Callable[[], tuple]) -> None:
        from rtcf._core import _rings

        self.seen: list[tuple] = []
        monkeypatch.setattr(_rings, "FENCED", True)
        monkeypatch.setattr(_rings, "acquire_fence", lambda: self.seen.append(("acq", *snapshot())))
        monkeypatch.setattr(_rings, "release_fence", lambda: self.seen.append(("rel", *snapshot())))


def test_a_producer_fences_between_the_record_and_the_head(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ring = _ring(64)
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_B_HEAD], ring.words[0], ring.words[1]))
    ring.push(struct.pack("q", 7))
    # one release fence, with the length and the record written and the head not moved
    assert spy.seen == [("rel", 0, 8, 7)]
    assert ctl[_B_HEAD] == 16
    ring.close()


def test_push_stamped_fences_between_the_record_and_the_head(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ring = _ring(64)
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_B_HEAD], ring.words[:4].tolist()))
    ring.push_stamped(5, 6, struct.pack("q", 7))
    assert spy.seen == [("rel", 0, [24, 5, 6, 7])]
    assert ctl[_B_HEAD] == 32
    ring.close()


@pytest.mark.parametrize("how", ["push", "push_stamped"])
def test_a_wrap_marker_is_written_before_the_fence_that_publishes_it(
    monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    ring = _ring(64)
    consumer = ByteRing.open(ring._ctl.obj)
    assert ring.push(bytes(24)) and ring.push(bytes(16))  # 0..32, 32..56
    consumer.pop()  # frees 0..32, which the producer has not seen free yet
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_B_TAIL], ctl[_B_HEAD], ring.words[7], ring.words[0]))
    # 16 or 24 bytes: 8 left before the end, so a marker at 56
    if how == "push":
        assert ring.push(bytes(8))
    else:
        assert ring.push_stamped(1, 2, b"")
    # the tail is read, then an acquire fence; the marker and the record, then a release
    length = 8 if how == "push" else 16
    assert spy.seen == [("acq", 32, 56, 0, 24), ("rel", 32, 56, -1, length)]
    assert ctl[_B_HEAD] == 64 + 8 + length
    consumer.close()
    ring.close()


def test_a_consumer_fences_after_the_head_and_before_the_tail(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ring = _ring(64)
    ring.push(struct.pack("q", 5))
    out = bytearray(8)
    ctl = ring._ctl
    spy = _FenceSpy(monkeypatch, lambda: (ctl[_B_TAIL], bytes(out)))
    position, _ = ring.pending()
    off, n, position = ring.record_at(position)
    out[:] = ring.data[off : off + n]
    ring.release_to(position)
    # acquire before the copy, release after it and before the tail moves
    assert spy.seen == [("acq", 0, bytes(8)), ("rel", 0, struct.pack("q", 5))]
    assert ctl[_B_TAIL] == 16
    ring.close()
