"""Lock-free channels in a buffer: rings of records and latest-value mailboxes.

A :class:`Ring` queue carries a stream (events, log records, timing rows: every
record matters, in order); a :class:`Mailbox` slot carries state (only the latest
value matters). Both live in any writable buffer: a bytearray inside one process,
or a shared-memory segment (:mod:`rtcf._runtime._shm`) mapped by the real-time
worker and the supervisor. Neither takes a lock or makes a system call, so the
real-time side never waits for the other side, whatever it is doing.

Memory ordering. Counters are aligned int64 words read and written through
``memoryview.cast("q")``; CPython copies such an item with one 8-byte ``memcpy``,
which compiles to a single machine load or store, so a word is never seen half
written. Each access is a separate call into C that the compiler cannot reorder,
and x86-64 keeps the rest in order (total store order): stores become visible to
other cores in program order, loads are not reordered with other loads, and a
store is not moved before an earlier load. So a producer that writes a record and
then the head counter publishes a complete record, and a consumer that reads the
head, then the record, then stores the tail never lets the producer reuse a slot
it is still reading. Weakly ordered CPUs (ARMv8, POWER, RISC-V) may reorder those
steps: there each one is separated by a fence from :mod:`rtcf._core._atomics` (a small
C extension, since Python cannot issue a fence), where :data:`FENCED` is true.
"""

from __future__ import annotations

import ctypes
import os
import platform
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ._closing import Closing
from ._hotpath import RingGate, WordTap

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer, WriteableBuffer

__all__ = ["FENCED", "TOTAL_STORE_ORDER", "Mailbox", "Ring"]

# x86 keeps stores, and loads, in program order (total store order): the channels need
# no fence there. On 32-bit x86 an 8-byte copy may also be split in two: counters below
# 2**31 are safe.
TOTAL_STORE_ORDER = platform.machine().lower() in ("x86_64", "amd64", "i686", "i386")

try:
    from ._atomics import acquire_fence, release_fence
except ImportError:
    if not TOTAL_STORE_ORDER:
        raise ImportError(
            f"rtcf's memory fences (rtcf._core._atomics) are not built, and a "
            f"{platform.machine()} CPU needs them for the channels between the real-time "
            f"worker and the supervisor: reinstall rtcf where a C compiler and the Python "
            f"headers are (apt-get install gcc python3-dev)"
        ) from None

    def acquire_fence() -> None:
        raise RuntimeError("rtcf._core._atomics is not built: FENCED must stay False")

    release_fence = acquire_fence

# Whether the channels call the fences: on every CPU that needs them. RTCF_FENCES=1
# turns them on where they are not needed (x86), so that the path weakly ordered CPUs
# take runs in every test; benchmarks/channels.py measures what it costs. Read by
# each channel operation (one global load and test): a test may switch it.
FENCED = not TOTAL_STORE_ORDER or os.environ.get("RTCF_FENCES", "") == "1"

_CACHE_LINE = 64


def _round_up(n: int, multiple: int) -> int:
    return -(-n // multiple) * multiple


def _byte_view(buf: WriteableBuffer) -> memoryview:
    """A flat writable byte view of ``buf`` whose start is 8-byte aligned in memory."""
    with memoryview(buf) as mv:
        if mv.readonly:
            raise ValueError("a channel needs a writable buffer (a Segment's buf, a bytearray)")
        if not mv.c_contiguous:
            raise ValueError("a channel needs a contiguous buffer")
        view = mv.cast("B")
    if len(view) == 0:
        view.release()
        raise ValueError("a channel needs a non-empty buffer")
    cell = ctypes.c_char.from_buffer(view)
    address = ctypes.addressof(cell)
    del cell
    if address % 8:
        view.release()
        # Unaligned words could be stored in two parts and read half-written.
        raise ValueError(
            "a channel buffer must start on an 8-byte boundary (slice a Segment's buf "
            "at a multiple of 64)"
        )
    return view


def _release(*views: memoryview) -> None:
    for view in views:
        view.release()


# A ring and a mailbox start with a header of int64 words, the magic number first.
# create() writes the magic number last and open() checks it first, so an opener
# never takes a header for complete while it is being written.
_MAGIC = 0


def _check_room(view: memoryview, need: int, what: str) -> None:
    """create(): ``view`` must hold ``need`` bytes for ``what`` it lays out."""
    if len(view) < need:
        raise ValueError(
            f"buffer of {len(view)} bytes is too small for {what} ({need} bytes needed)"
        )


def _write_header(view: memoryview, nbytes: int, fields: dict[int, int], magic: int) -> None:
    """Zero the first ``nbytes`` of ``view``, set the header words ``fields``, then the
    magic number."""
    with view[:nbytes].cast("q") as words:
        for i in range(len(words)):
            words[i] = 0
        for at, value in fields.items():
            words[at] = value
        words[_MAGIC] = magic  # last: an opener sees a complete header


def _read_header(
    view: memoryview, header: int, magic: int, kind: str, fields: tuple[int, ...]
) -> tuple[int, ...]:
    """open(): the header words ``fields`` of the ``kind`` (Ring, Mailbox) laid out at
    the start of ``view``, once its magic number says it is one."""
    what = kind.lower()
    if len(view) < header:
        raise ValueError(f"buffer of {len(view)} bytes is too small to hold a {what}")
    with view[:header].cast("q") as words:
        found = words[_MAGIC]
        values = tuple(words[at] for at in fields)
    if found != magic:
        raise ValueError(
            f"buffer does not hold an rtcf {what} (bad magic number): "
            f"was it laid out with {kind}.create()?"
        )
    return values


def _check_length(view: memoryview, need: int, what: str) -> None:
    """open(): ``view`` must be as long as the ``what`` its header describes."""
    if len(view) < need:
        raise ValueError(f"buffer of {len(view)} bytes is shorter than its {what} ({need} bytes)")


# Ring header: int64 words. Line 0 is written once by create(); line 1 only by the
# producer; line 2 only by the consumer (separate cache lines: no false sharing).
_RING_MAGIC = int.from_bytes(b"rtcfRNG1", "little")
_R_CAPACITY, _R_RECORD_SIZE = 1, 2  # after the magic number
_R_HEAD, _R_DROPPED = 8, 9
_R_TAIL = 16
_RING_HEADER = 3 * _CACHE_LINE


class Ring(Closing):
    """Bounded lock-free single-producer/single-consumer ring of fixed-size records.

    It lives in a buffer (usually a Segment's buf, possibly at an offset; or a
    bytearray for in-process use). Head and tail are counts of records committed and
    released, never wrapped, so full and empty are told apart without a spare slot.
    When full, the producer drops the new record and counts it: the real-time side
    never waits for a slow consumer. Use one object per side: the producer on the
    one side and the consumer on the other.
    """

    __slots__ = ("_ctl", "_mask", "_next", "_tail_seen", "capacity", "data", "record_size")

    def __init__(self, view: memoryview, capacity: int, record_size: int) -> None:
        self.capacity = capacity
        self.record_size = record_size
        self._mask = capacity - 1
        self._ctl = view[:_RING_HEADER].cast("q")
        self.data = view[_RING_HEADER : _RING_HEADER + capacity * record_size]
        self._tail_seen = self._ctl[_R_TAIL]  # a lower bound of the tail (it only grows)
        if FENCED:  # the consumer's reads of the slots before this tail, before our writes
            acquire_fence()
        self._next = 0  # head after the reserved record; 0 when none is reserved

    @staticmethod
    def nbytes(capacity: int, record_size: int) -> int:
        """Bytes a ring needs; capacity rounds up to a power of two, record size to 8."""
        capacity, record_size = _ring_shape(capacity, record_size)
        return _RING_HEADER + capacity * record_size

    @classmethod
    def create(cls, buf: WriteableBuffer, capacity: int, record_size: int) -> Ring:
        """Lay out an empty ring at the start of ``buf``."""
        capacity, record_size = _ring_shape(capacity, record_size)
        view = _byte_view(buf)
        try:
            need = _RING_HEADER + capacity * record_size
            _check_room(view, need, f"a ring of {capacity} records of {record_size} bytes")
            fields = {_R_CAPACITY: capacity, _R_RECORD_SIZE: record_size}
            _write_header(view, _RING_HEADER, fields, _RING_MAGIC)
            return cls(view, capacity, record_size)
        finally:
            view.release()

    @classmethod
    def open(cls, buf: WriteableBuffer) -> Ring:
        """Attach to the ring another process (or object) created in ``buf``."""
        view = _byte_view(buf)
        try:
            capacity, record_size = _read_header(
                view, _RING_HEADER, _RING_MAGIC, "Ring", (_R_CAPACITY, _R_RECORD_SIZE)
            )
            if capacity <= 0 or capacity & (capacity - 1) or record_size <= 0 or record_size % 8:
                raise ValueError(
                    f"corrupt ring header: capacity {capacity}, record size {record_size}"
                )
            _check_length(view, _RING_HEADER + capacity * record_size, "ring")
            return cls(view, capacity, record_size)
        finally:
            view.release()

    def close(self) -> None:
        """Release the views into the buffer (so its Segment can close). Idempotent."""
        _release(self._ctl, self.data)

    # -- producer side ---------------------------------------------------------

    def reserve(self) -> int:
        """Byte offset in ``data`` of the next free record; -1 (and one drop) if full."""
        ctl = self._ctl
        head = ctl[_R_HEAD]
        if head - self._tail_seen >= self.capacity:
            # Looks full from the cached tail: only now read the consumer's line.
            tail = self._tail_seen = ctl[_R_TAIL]
            if FENCED:  # the consumer is done reading the slots it released
                acquire_fence()
            if head - tail >= self.capacity:
                ctl[_R_DROPPED] += 1
                self._next = 0
                return -1
        self._next = head + 1
        return (head & self._mask) * self.record_size

    def commit(self) -> None:
        """Publish the record reserved last: the head moves only after it is written."""
        head = self._next
        if not head:
            raise RuntimeError("Ring.commit() without a successful reserve()")
        if FENCED:  # the record, then the head
            release_fence()
        self._ctl[_R_HEAD] = head
        self._next = 0

    def push(self, record: ReadableBuffer) -> bool:
        """Copy ``record`` (at most record_size bytes) into the ring; False if dropped."""
        if type(record) is bytes or type(record) is bytearray:
            return self._push(record)
        with memoryview(record) as mv, mv.cast("B") as flat:
            return self._push(flat)

    def _push(self, record: bytes | bytearray | memoryview) -> bool:
        n = len(record)
        if n > self.record_size:
            raise ValueError(
                f"record of {n} bytes does not fit the ring's {self.record_size}-byte records"
            )
        # reserve() and commit() inlined: this is the real-time hot path.
        ctl = self._ctl
        head = ctl[_R_HEAD]
        if head - self._tail_seen >= self.capacity:
            tail = self._tail_seen = ctl[_R_TAIL]
            if FENCED:
                acquire_fence()
            if head - tail >= self.capacity:
                ctl[_R_DROPPED] += 1
                return False
        offset = (head & self._mask) * self.record_size
        self.data[offset : offset + n] = record
        if FENCED:
            release_fence()
        ctl[_R_HEAD] = head + 1
        return True

    def push_all(self, records: list[bytes]) -> bool:
        """Commit ``records`` together, or none of them (False, and one drop, when they
        do not all fit now): the consumer sees all of them at once, never a part. Not
        for the real-time side (it builds nothing, but loops in Python)."""
        n = len(records)
        if n > self.capacity or any(len(r) > self.record_size for r in records):
            raise ValueError(
                f"{n} records do not fit the ring's {self.capacity} records of "
                f"{self.record_size} bytes"
            )
        ctl = self._ctl
        head = ctl[_R_HEAD]
        if head + n - self._tail_seen > self.capacity:
            tail = self._tail_seen = ctl[_R_TAIL]
            if FENCED:
                acquire_fence()
            if head + n - tail > self.capacity:
                ctl[_R_DROPPED] += 1
                return False
        for k, record in enumerate(records):
            offset = ((head + k) & self._mask) * self.record_size
            self.data[offset : offset + len(record)] = record
        if FENCED:  # every record, then the one head that covers them
            release_fence()
        ctl[_R_HEAD] = head + n
        return True

    def push_words(self, words: Any, values: Any, a: int, b: int, c: int, d: Any) -> bool:
        """Commit a record whose first four 8-byte words are ``a``, ``b``, ``c`` (into
        ``words``, ``data`` cast to int64) and ``d`` (into ``values``: ``words``, or
        ``data`` cast to float64); False, and one drop, if the ring is full. One call
        where reserve, stores and commit would be three: a recording's hot path."""
        ctl = self._ctl
        head = ctl[_R_HEAD]
        if head - self._tail_seen >= self.capacity:
            tail = self._tail_seen = ctl[_R_TAIL]
            if FENCED:
                acquire_fence()
            if head - tail >= self.capacity:
                ctl[_R_DROPPED] += 1
                return False
        w = ((head & self._mask) * self.record_size) >> 3
        words[w] = a
        words[w + 1] = b
        words[w + 2] = c
        values[w + 3] = d
        if FENCED:
            release_fence()
        ctl[_R_HEAD] = head + 1
        return True

    def word_tap(self, state: Any, kind: str) -> Any:
        """A callable that pushes ``push_words``' record (8 or 1 bytes, the state's
        iteration and stamp, the value as ``kind``: float, int or bool) for each value
        it is called with: compiled, for a port's write to call (None on the Python
        hot path). ``release()`` it before this ring closes."""
        if WordTap is None:
            return None
        return WordTap(self._ctl, self.data, _R_HEAD, _R_DROPPED, _R_TAIL, self.capacity,
                       self.record_size, state, kind)

    @property
    def dropped(self) -> int:
        """Records dropped because the ring was full (kept in the shared header)."""
        return self._ctl[_R_DROPPED]

    @property
    def produced(self) -> int:
        """Records committed so far (the head count)."""
        return self._ctl[_R_HEAD]

    # -- consumer side ---------------------------------------------------------

    def when_pending(self, fn: Callable[[], object]) -> RingGate:
        """A callable that calls ``fn`` only when records wait: two word reads in the
        common case (a loop's feeder). ``release()`` it before this ring closes."""
        return RingGate(self._ctl, _R_HEAD, _R_TAIL, fn)

    def __len__(self) -> int:
        ctl = self._ctl
        return ctl[_R_HEAD] - ctl[_R_TAIL]

    def pending(self) -> tuple[int, int]:
        """(first slot, n) of waiting records contiguous in ``data``, up to the wrap.

        Process them in place, then :meth:`release` them; call again for the part
        after the wrap.
        """
        ctl = self._ctl
        tail = ctl[_R_TAIL]
        n = ctl[_R_HEAD] - tail
        if FENCED:  # the head, then the records it covers
            acquire_fence()
        slot = tail & self._mask
        room = self.capacity - slot
        return slot, (n if n < room else room)

    def release(self, n: int) -> None:
        """Hand ``n`` consumed records back to the producer."""
        ctl = self._ctl
        tail = ctl[_R_TAIL]
        waiting = ctl[_R_HEAD] - tail
        if not 0 <= n <= waiting:
            raise ValueError(f"cannot release {n} records: {waiting} are waiting")
        if FENCED:  # done reading the records, then hand their slots back
            release_fence()
        ctl[_R_TAIL] = tail + n

    def pop(self) -> bytes | None:
        """The oldest record, copied out; None if the ring is empty."""
        ctl = self._ctl
        tail = ctl[_R_TAIL]
        if ctl[_R_HEAD] == tail:
            return None
        if FENCED:
            acquire_fence()
        offset = (tail & self._mask) * self.record_size
        record = self.data[offset : offset + self.record_size].tobytes()
        if FENCED:
            release_fence()
        ctl[_R_TAIL] = tail + 1
        return record

    def pop_into(self, out: WriteableBuffer) -> bool:
        """Copy the oldest record into ``out`` (record_size bytes or more); False if empty."""
        ctl = self._ctl
        tail = ctl[_R_TAIL]
        size = self.record_size
        if type(out) is bytearray:  # fast path: no views to make
            if len(out) < size:
                raise ValueError(f"output buffer of {len(out)} bytes, records have {size}")
            if ctl[_R_HEAD] == tail:
                return False
            if FENCED:
                acquire_fence()
            offset = (tail & self._mask) * size
            out[:size] = self.data[offset : offset + size]
        else:
            with memoryview(out) as mv, mv.cast("B") as flat:
                if len(flat) < size:
                    raise ValueError(f"output buffer of {len(flat)} bytes, records have {size}")
                if ctl[_R_HEAD] == tail:
                    return False
                if FENCED:
                    acquire_fence()
                offset = (tail & self._mask) * size
                flat[:size] = self.data[offset : offset + size]
        if FENCED:
            release_fence()
        ctl[_R_TAIL] = tail + 1
        return True

    def __repr__(self) -> str:
        try:
            return (
                f"<Ring {self.capacity} x {self.record_size} bytes, {len(self)} waiting, "
                f"{self.dropped} dropped>"
            )
        except ValueError:  # views released
            return "<Ring closed>"


def _ring_shape(capacity: int, record_size: int) -> tuple[int, int]:
    if capacity < 1:
        raise ValueError(f"ring capacity must be at least 1, not {capacity}")
    if record_size < 1:
        raise ValueError(f"ring record size must be at least 1 byte, not {record_size}")
    return 1 << (capacity - 1).bit_length(), _round_up(record_size, 8)


# Mailbox header: line 0 written once by create(); line 1 by the writer. Each of
# the two buffers has a line of its own (sequence, length) and then the payload.
_MAILBOX_MAGIC = int.from_bytes(b"rtcfMBX1", "little")
_M_SIZE = 1  # after the magic number
_M_LATEST, _M_VERSION = 8, 9
_M_SEQ, _M_LENGTH, _M_STAMP = 0, 1, 2  # _M_STAMP: the write count of the value held
_MAILBOX_HEADER = 2 * _CACHE_LINE


def _mailbox_stride(size: int) -> int:
    return _CACHE_LINE + _round_up(size, _CACHE_LINE)


class Mailbox(Closing):
    """Latest-value mailbox (seqlock), single writer, single reader, for state.

    Two buffers: the writer fills the one the reader is not on, then publishes it,
    so the reader almost never finds the value mid-write; when it does (the writer
    wrote twice during one read), the sequence word tells, and the reader keeps its
    previous value instead of waiting. Each value carries its write count, so a
    reader that followed a 'latest' word read just before the writer flipped it
    never returns a value older than one it already returned (found by the
    million-write test between processes).
    """

    __slots__ = ("_ctl", "_meta", "_newest", "_payload", "size")

    def __init__(self, view: memoryview, size: int) -> None:
        self.size = size
        # the stamp of the newest value this reader returned: a reader that followed a
        # stale 'latest' to the other buffer must not go back to an older value
        self._newest = 0
        stride = _mailbox_stride(size)
        starts = (_MAILBOX_HEADER, _MAILBOX_HEADER + stride)
        self._ctl = view[:_MAILBOX_HEADER].cast("q")
        self._meta = tuple(view[s : s + _CACHE_LINE].cast("q") for s in starts)
        self._payload = tuple(view[s + _CACHE_LINE : s + _CACHE_LINE + size] for s in starts)

    @staticmethod
    def nbytes(size: int) -> int:
        """Bytes a mailbox for payloads of up to ``size`` bytes needs."""
        if size < 0:
            raise ValueError(f"mailbox size must not be negative, not {size}")
        return _MAILBOX_HEADER + 2 * _mailbox_stride(size)

    @classmethod
    def create(cls, buf: WriteableBuffer, size: int) -> Mailbox:
        """Lay out an empty (never written) mailbox at the start of ``buf``."""
        need = cls.nbytes(size)
        view = _byte_view(buf)
        try:
            _check_room(view, need, f"a mailbox of {size} bytes")
            _write_header(view, need, {_M_SIZE: size}, _MAILBOX_MAGIC)
            return cls(view, size)
        finally:
            view.release()

    @classmethod
    def open(cls, buf: WriteableBuffer) -> Mailbox:
        """Attach to the mailbox another process (or object) created in ``buf``."""
        view = _byte_view(buf)
        try:
            (size,) = _read_header(view, _MAILBOX_HEADER, _MAILBOX_MAGIC, "Mailbox", (_M_SIZE,))
            _check_length(view, cls.nbytes(size), "mailbox")
            return cls(view, size)
        finally:
            view.release()

    def close(self) -> None:
        """Release the views into the buffer (so its Segment can close). Idempotent."""
        _release(self._ctl, *self._meta, *self._payload)

    def write(self, data: ReadableBuffer) -> None:
        """Publish a new value (at most ``size`` bytes). Single writer."""
        if type(data) is bytes or type(data) is bytearray:
            self._write(data)
        else:
            with memoryview(data) as mv, mv.cast("B") as flat:
                self._write(flat)

    def _write(self, data: bytes | bytearray | memoryview) -> None:
        n = len(data)
        if n > self.size:
            raise ValueError(f"mailbox payload of {n} bytes exceeds its size of {self.size} bytes")
        ctl = self._ctl
        b = 1 - ctl[_M_LATEST]  # the buffer a reader that starts now will not pick
        meta = self._meta[b]
        seq = meta[_M_SEQ]
        meta[_M_SEQ] = seq + 1  # odd: being written
        if FENCED:  # odd before any of the payload
            release_fence()
        self._payload[b][:n] = data
        meta[_M_LENGTH] = n
        version = ctl[_M_VERSION] + 1
        meta[_M_STAMP] = version
        if FENCED:  # the payload before even
            release_fence()
        meta[_M_SEQ] = seq + 2  # even: complete
        if FENCED:  # a reader that follows 'latest' here finds the buffer complete
            release_fence()
        ctl[_M_LATEST] = b
        ctl[_M_VERSION] = version

    def try_read_into(self, out: WriteableBuffer) -> int:
        """One attempt to copy the latest value into ``out``; never waits.

        Returns the payload length, -1 if never written, or -2 if the value changed
        during the copy (keep the previous value and try again next time; ``out``
        may then hold a partial copy).
        """
        b = self._ctl[_M_LATEST]
        if FENCED:  # 'latest', then its buffer's sequence
            acquire_fence()
        meta = self._meta[b]
        seq = meta[_M_SEQ]
        if seq & 1:
            return -2
        if not seq:
            return -1
        if FENCED:  # the sequence, then the payload
            acquire_fence()
        stamp = meta[_M_STAMP]
        if stamp < self._newest:  # older than what this reader already returned
            return -2
        n = meta[_M_LENGTH]
        payload = self._payload[b]
        if n != self.size:
            payload = payload[:n]
        if type(out) is bytearray:  # fast path: no views to make
            if n > len(out):
                self._too_small(len(out), n, meta, seq)
                return -2
            out[:n] = payload
        else:
            with memoryview(out) as mv, mv.cast("B") as flat:
                if n > len(flat):
                    self._too_small(len(flat), n, meta, seq)
                    return -2
                flat[:n] = payload
        if FENCED:  # the payload, then the sequence again
            acquire_fence()
        if meta[_M_SEQ] != seq:
            return -2
        self._newest = stamp
        return n

    @staticmethod
    def _too_small(room: int, n: int, meta: memoryview, seq: int) -> None:
        """Raise unless the length was read mid-write (then the caller returns -2)."""
        if meta[_M_SEQ] == seq:
            raise ValueError(f"output buffer of {room} bytes, the value has {n}")

    def read(self, retries: int = 1000) -> bytes | None:
        """The latest value (non-real-time side: retries while it is being rewritten)."""
        out = bytearray(self.size)
        for _ in range(max(1, retries)):
            n = self.try_read_into(out)
            if n >= 0:
                return bytes(out[:n])
            if n == -1:
                return None
        raise RuntimeError(
            f"mailbox value kept changing during {max(1, retries)} read attempts"
        )

    @property
    def version(self) -> int:
        """Completed writes: a reader compares it with the last one it saw."""
        return self._ctl[_M_VERSION]

    @property
    def stamp(self) -> int:
        """The write count of the value this reader last returned (0: none yet): how
        many writes there were up to it, so a reader can count the ones it never saw."""
        return self._newest

    def __repr__(self) -> str:
        try:
            return f"<Mailbox {self.size} bytes, version {self.version}>"
        except ValueError:  # views released
            return "<Mailbox closed>"
