"""A lock-free ring of variable-length records in a buffer: as many records as their bytes.

A :class:`rtcf._core._rings.Ring` gives every record the same size, so a stream whose
records may be large (a float array, a ROS message: up to 64 KiB) but usually are not
(three floats: 24 bytes) holds few of them. A :class:`ByteRing` holds bytes instead:
each record is one int64 word, its length, then the record padded to 8 bytes, so a
ring of 4 MiB holds 87,000 records of three floats and still 63 of 64 KiB.

Head and tail count bytes, never wrapped (full and empty are told apart without a
spare byte). A record never straddles the end of the data: when it does not fit
before the end, the producer writes a *wrap marker* (a length of -1) where it would
have started, and the record at the start; the marker's bytes to the end count as
used until the consumer passes them. So a record of up to half the ring always fits
once the consumer has caught up, and larger ones are refused (``max_record``).

Single producer, single consumer, like a Ring, with the same memory-ordering
discipline and fences (:mod:`rtcf._core._rings`, whose :data:`FENCED` switch and
fences these are): the producer writes the record (and the marker), a release fence,
then the head; it reads the consumer's tail only when the ring looks full from the
tail it saw last, with an acquire fence after it. The consumer reads the head, an
acquire fence, then the records; a release fence, then the tail. The producer never
waits: a record that finds too few free bytes is dropped and counted in the header.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import _rings
from ._closing import Closing
from ._rings import (
    _CACHE_LINE,
    _byte_view,
    _check_length,
    _check_room,
    _read_header,
    _release,
    _write_header,
)

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer, WriteableBuffer

__all__ = ["ByteRing"]

# Header: int64 words. Line 0 is written once by create(); line 1 only by the producer;
# line 2 only by the consumer (separate cache lines: no false sharing).
_MAGIC = int.from_bytes(b"rtcfBRG1", "little")
_B_SIZE = 1  # after the magic number: the data's bytes, a power of two
_B_HEAD, _B_DROPPED = 8, 9
_B_TAIL = 16
_HEADER = 3 * _CACHE_LINE
_WRAP = -1  # a length word that says: the next record is at the start of the data
_MIN_SIZE = 64


def record_bytes(n: int) -> int:
    """Bytes of the ring a record of ``n`` bytes takes: its length word, itself padded
    to 8."""
    return 8 + ((n + 7) & ~7)


class ByteRing(Closing):
    """Bounded lock-free single-producer/single-consumer ring of variable-length records.

    Producer: :meth:`reserve` the bytes of a record, write them at the offset it
    returns, :meth:`commit`; or :meth:`push` a buffer. Consumer: :meth:`pending` gives
    the byte positions of what waits, :meth:`record_at` walks them (past the wrap
    markers), :meth:`release_to` hands them back; or :meth:`pop` one copied out. Use one
    object per side.
    """

    __slots__ = ("_ctl", "_mask", "_next", "_tail_seen", "data", "max_record", "size", "words")

    def __init__(self, view: memoryview, size: int) -> None:
        self.size = size
        self._mask = size - 1
        self.max_record = size // 2 - 8  # the longest record that always fits, in time
        self._ctl = view[:_HEADER].cast("q")
        self.data = view[_HEADER : _HEADER + size]
        # the data as int64 words: a record's offset >> 3 is the index of its first
        self.words = self.data.cast("q")
        self._tail_seen = self._ctl[_B_TAIL]  # a lower bound of the tail (it only grows)
        if _rings.FENCED:  # the consumer's reads of the bytes before this tail, first
            _rings.acquire_fence()
        self._next = 0  # head after the reserved record; 0 when none is reserved

    @staticmethod
    def nbytes(size: int) -> int:
        """Bytes a ring of ``size`` bytes of records needs (size rounds up to a power of
        two, 64 at least)."""
        return _HEADER + _ring_size(size)

    @classmethod
    def create(cls, buf: WriteableBuffer, size: int) -> ByteRing:
        """Lay out an empty ring of ``size`` bytes of records at the start of ``buf``."""
        size = _ring_size(size)
        view = _byte_view(buf)
        try:
            _check_room(view, _HEADER + size, f"a byte ring of {size} bytes")
            _write_header(view, _HEADER, {_B_SIZE: size}, _MAGIC)
            return cls(view, size)
        finally:
            view.release()

    @classmethod
    def open(cls, buf: WriteableBuffer) -> ByteRing:
        """Attach to the ring another process (or object) created in ``buf``."""
        view = _byte_view(buf)
        try:
            (size,) = _read_header(view, _HEADER, _MAGIC, "ByteRing", (_B_SIZE,))
            if size < _MIN_SIZE or size & (size - 1):
                raise ValueError(f"corrupt byte ring header: size {size}")
            _check_length(view, _HEADER + size, "byte ring")
            return cls(view, size)
        finally:
            view.release()

    def close(self) -> None:
        """Release the views into the buffer (so its Segment can close). Idempotent."""
        _release(self.words, self._ctl, self.data)

    # -- producer side ---------------------------------------------------------

    def reserve(self, n: int) -> int:
        """Byte offset in ``data`` where a record of ``n`` bytes goes (8-aligned); -1,
        and one drop, if the free bytes do not hold it now. Its length (and a wrap
        marker before it) are written already; the consumer sees it at :meth:`commit`.
        A record longer than ``max_record`` is an error: it might never fit."""
        if n > self.max_record or n < 0:
            raise ValueError(
                f"record of {n} bytes does not fit a byte ring of {self.size} bytes "
                f"({self.max_record} at most)"
            )
        need = 8 + ((n + 7) & ~7)
        ctl = self._ctl
        head = ctl[_B_HEAD]
        at = head & self._mask
        skip = self.size - at if at + need > self.size else 0  # to the end: a wrap marker
        if head + skip + need - self._tail_seen > self.size:
            # looks full from the cached tail: only now read the consumer's line
            tail = self._tail_seen = ctl[_B_TAIL]
            if _rings.FENCED:  # the consumer is done reading the bytes it released
                _rings.acquire_fence()
            if head + skip + need - tail > self.size:
                ctl[_B_DROPPED] += 1
                self._next = 0
                return -1
        words = self.words
        if skip:
            words[at >> 3] = _WRAP
            at = 0
        words[at >> 3] = n
        self._next = head + skip + need
        return at + 8

    def commit(self) -> None:
        """Publish the record reserved last: the head moves only after it is written."""
        head = self._next
        if not head:
            raise RuntimeError("ByteRing.commit() without a successful reserve()")
        if _rings.FENCED:  # the record (and its marker), then the head
            _rings.release_fence()
        self._ctl[_B_HEAD] = head
        self._next = 0

    def push(self, record: ReadableBuffer) -> bool:
        """Copy ``record`` into the ring as one record; False (and one drop) if it does
        not fit now."""
        if type(record) is bytes or type(record) is bytearray:
            return self._push(record)
        with memoryview(record) as mv, mv.cast("B") as flat:
            return self._push(flat)

    def _push(self, record: bytes | bytearray | memoryview) -> bool:
        n = len(record)
        at = self.reserve(n)
        if at < 0:
            return False
        self.data[at : at + n] = record
        self.commit()
        return True

    def push_stamped(
        self, first: int, second: int, payload: bytes | bytearray | memoryview
    ) -> bool:
        """Commit a record of two int64 words, ``first`` and ``second``, then the bytes of
        ``payload`` (bytes, a bytearray or a 1-D byte view); False, and one drop, if it
        does not fit now. One call where reserve, stores, copy and commit would be
        several: a recording's hot path (the iteration, its stamp, the value)."""
        n = len(payload)
        size = self.size
        need = 24 + ((n + 7) & ~7)
        if need > (size >> 1):
            raise ValueError(
                f"record of {n + 16} bytes does not fit a byte ring of {size} bytes "
                f"({self.max_record} at most)"
            )
        # reserve() and commit() inlined
        ctl = self._ctl
        head = ctl[_B_HEAD]
        at = head & self._mask
        end = head + need
        if at + need > size:
            end += size - at  # and a wrap marker at `at`
        if end - self._tail_seen > size:
            tail = self._tail_seen = ctl[_B_TAIL]
            if _rings.FENCED:
                _rings.acquire_fence()
            if end - tail > size:
                ctl[_B_DROPPED] += 1
                return False
        words = self.words
        if at + need > size:
            words[at >> 3] = _WRAP
            at = 0
        w = at >> 3
        words[w] = n + 16
        words[w + 1] = first
        words[w + 2] = second
        self.data[at + 24 : at + 24 + n] = payload
        if _rings.FENCED:  # the record (and its marker), then the head
            _rings.release_fence()
        ctl[_B_HEAD] = end
        return True

    def fits(self, n: int) -> bool:
        """Whether a record of ``n`` bytes would fit now (reads the consumer's tail): for
        a producer that may wait for room (a simulated clock), never the real-time one."""
        need = 8 + ((n + 7) & ~7)
        ctl = self._ctl
        head = ctl[_B_HEAD]
        at = head & self._mask
        skip = self.size - at if at + need > self.size else 0
        tail = self._tail_seen = ctl[_B_TAIL]
        if _rings.FENCED:
            _rings.acquire_fence()
        return head + skip + need - tail <= self.size

    @property
    def dropped(self) -> int:
        """Records dropped because the ring was too full (kept in the shared header)."""
        return self._ctl[_B_DROPPED]

    # -- consumer side ---------------------------------------------------------

    def __len__(self) -> int:
        """Bytes waiting (records, their length words and padding, wrap markers)."""
        ctl = self._ctl
        return ctl[_B_HEAD] - ctl[_B_TAIL]

    def pending(self) -> tuple[int, int]:
        """(tail, head): the byte positions between which committed records wait. Walk
        them with :meth:`record_at`, then :meth:`release_to` where the walk ended."""
        ctl = self._ctl
        tail = ctl[_B_TAIL]
        head = ctl[_B_HEAD]
        if _rings.FENCED:  # the head, then the records it covers
            _rings.acquire_fence()
        return tail, head

    def record_at(self, position: int) -> tuple[int, int, int]:
        """(offset in ``data``, length, position of the next) of the record at byte
        ``position`` (one from :meth:`pending`, before its head), past a wrap marker."""
        at = position & self._mask
        n = self.words[at >> 3]
        if n == _WRAP:
            position += self.size - at
            at = 0
            n = self.words[0]
        if not 0 <= n <= self.max_record:
            raise ValueError(f"corrupt byte ring: a record of {n} bytes at {position}")
        return at + 8, n, position + 8 + ((n + 7) & ~7)

    def release_to(self, position: int) -> None:
        """Hand the bytes before ``position`` (a record's end) back to the producer."""
        ctl = self._ctl
        tail = ctl[_B_TAIL]
        head = ctl[_B_HEAD]
        if not tail <= position <= head:
            raise ValueError(f"cannot release to byte {position}: the records are {tail}..{head}")
        if _rings.FENCED:  # done reading the records, then hand their bytes back
            _rings.release_fence()
        ctl[_B_TAIL] = position

    def pop(self) -> bytes | None:
        """The oldest record, copied out; None if the ring is empty."""
        tail, head = self.pending()
        if tail == head:
            return None
        at, n, end = self.record_at(tail)
        record = self.data[at : at + n].tobytes()
        self.release_to(end)
        return record

    def __repr__(self) -> str:
        try:
            return f"<ByteRing {self.size} bytes, {len(self)} waiting, {self.dropped} dropped>"
        except ValueError:  # views released
            return "<ByteRing closed>"


def _ring_size(size: int) -> int:
    if size < 1:
        raise ValueError(f"byte ring size must be at least 1 byte, not {size}")
    return max(_MIN_SIZE, 1 << (size - 1).bit_length())
