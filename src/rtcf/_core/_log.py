"""Real-time safe logging: records go into a preallocated ring; I/O happens elsewhere.

Calling ``self.log.info("x=%s", x)`` from ``update`` puts the record into a slot
that already exists; no I/O happens in the loop. In the worker process
(:class:`LogWriter`) the slot is in shared memory and the message is formatted at
the call (the supervisor cannot format another process's objects); the supervisor
drains the ring (:func:`drain_channel`) and hands the records to Python's
``logging`` (and later to ROS). A runner without a worker (tests, ``Runner`` used
directly) keeps a :class:`LogRing` of unformatted records in its own memory. When a
ring is full the record is dropped and counted; the count is reported, never hidden.

``self.log.nonrt`` is the original's ``NON_RT_*`` logging: for configure, start,
stop and cleanup; it never drops, and raises if called while the loop runs.
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable
from typing import Any, Protocol

from ._errors import RtcfError
from ._loop_state import LoopState
from ._rings import Ring


class LogLevel(enum.IntEnum):
    DEBUG = 10
    INFO = 20
    WARNING = 30
    ERROR = 40
    FATAL = 50


class LogRecord:
    """One slot of the ring (reused, never reallocated)."""

    __slots__ = ("args", "iteration", "level", "logger", "msg", "time_ns")

    def __init__(
        self, level: int = 0, logger: str = "", msg: str = "", iteration: int = -1, time_ns: int = 0
    ) -> None:
        self.level = level
        self.logger = logger
        self.msg = msg
        self.args: tuple[Any, ...] = ()
        self.iteration = iteration
        self.time_ns = time_ns

    def format(self) -> str:
        return format_message(self.msg, self.args)


class LogRing:
    """A bounded single-producer/single-consumer ring of log records."""

    __slots__ = ("_head", "_mask", "_records", "_tail", "dropped")

    def __init__(self, capacity: int = 4096) -> None:
        size = 1
        while size < capacity:
            size <<= 1
        self._records = [LogRecord() for _ in range(size)]
        self._mask = size - 1
        self._head = 0  # next slot to write (producer)
        self._tail = 0  # next slot to read (consumer)
        self.dropped = 0

    @property
    def capacity(self) -> int:
        return self._mask + 1

    def __len__(self) -> int:
        return self._head - self._tail

    def push(
        self, level: int, logger: str, msg: str, args: tuple[Any, ...], iteration: int, time_ns: int
    ) -> bool:
        head = self._head
        if head - self._tail > self._mask:
            self.dropped += 1
            return False
        rec = self._records[head & self._mask]
        rec.level = level
        rec.logger = logger
        rec.msg = msg
        rec.args = args
        rec.iteration = iteration
        rec.time_ns = time_ns
        self._head = head + 1
        return True

    def drain(self, sink: Callable[[LogRecord], None], limit: int | None = None) -> int:
        """Hand up to ``limit`` records to ``sink`` in order; return how many."""
        n = 0
        while self._tail != self._head and (limit is None or n < limit):
            rec = self._records[self._tail & self._mask]
            sink(rec)
            rec.args = ()  # let go of the arguments
            self._tail += 1
            n += 1
        return n


class RecordSink(Protocol):
    """Where a logger's records go: an in-process ring or a shared-memory channel."""

    @property
    def dropped(self) -> int: ...

    def push(
        self, level: int, logger: str, msg: str, args: tuple[Any, ...], iteration: int, time_ns: int
    ) -> bool: ...


# layout of a log record in a shared-memory ring: six int64 words, the logger name, the text
_W_LEVEL, _W_ITERATION, _W_TIME, _W_NAME_LEN, _W_TEXT_LEN, _W_TRUNCATED = range(6)
_HEADER = 48
NAME_MAX = 128
LOG_RECORD_SIZE = 1024  # bytes per record; longer messages are cut and marked


def format_message(msg: str, args: tuple[Any, ...]) -> str:
    if not args:
        return str(msg)
    try:
        return str(msg) % args
    except (TypeError, ValueError) as exc:
        return f"{msg!r} % {args!r} (bad log format: {exc})"


class LogWriter:
    """Producer side of a log channel in shared memory (the worker's end).

    The message is formatted at the call (the values may change later; another
    process cannot format them) and copied into a slot that already exists. A full
    ring drops the record; the ring counts it in shared memory.
    """

    __slots__ = ("_data", "_ring", "_space", "_words")

    def __init__(self, ring: Ring) -> None:
        if ring.record_size < _HEADER + NAME_MAX + 64:
            raise ValueError(f"log records of {ring.record_size} bytes are too small")
        self._ring = ring
        self._data = ring.data
        self._words = ring.data.cast("q")
        self._space = ring.record_size - _HEADER

    @property
    def dropped(self) -> int:
        return self._ring.dropped

    def push(
        self, level: int, logger: str, msg: str, args: tuple[Any, ...], iteration: int, time_ns: int
    ) -> bool:
        off = self._ring.reserve()
        if off < 0:
            return False
        self._fill(off, level, logger, format_message(msg, args), iteration, time_ns)
        self._ring.commit()
        return True

    def push_waiting(
        self, level: int, logger: str, text: str, iteration: int, time_ns: int, timeout_s: float
    ) -> bool:
        """Outside the loop: wait (up to ``timeout_s``) for the supervisor to make room."""
        ring = self._ring
        give_up = time.monotonic() + timeout_s
        while len(ring) >= ring.capacity:
            if time.monotonic() > give_up:
                break
            time.sleep(0.001)
        off = ring.reserve()
        if off < 0:
            return False
        self._fill(off, level, logger, text, iteration, time_ns)
        ring.commit()
        return True

    def _fill(self, off: int, level: int, logger: str, text: str, iteration: int, t: int) -> None:
        name = logger.encode("utf-8", "replace")[:NAME_MAX]
        body = text.encode("utf-8", "replace")
        room = self._space - len(name)
        cut = len(body) > room
        if cut:
            body = body[:room]
        start = off + _HEADER
        self._data[start : start + len(name)] = name
        start += len(name)
        self._data[start : start + len(body)] = body
        w = self._words
        b = off >> 3
        w[b + _W_LEVEL] = level
        w[b + _W_ITERATION] = iteration
        w[b + _W_TIME] = t
        w[b + _W_NAME_LEN] = len(name)
        w[b + _W_TEXT_LEN] = len(body)
        w[b + _W_TRUNCATED] = 1 if cut else 0

    def release(self) -> None:
        """Let go of the shared memory (before its segment is closed)."""
        self._words.release()
        self._ring.close()


def drain_channel(ring: Ring, sink: Callable[[LogRecord], None], limit: int | None = None) -> int:
    """Consumer side: decode the records waiting in ``ring`` and hand them to ``sink``."""
    rec = LogRecord()
    n = 0
    size = ring.record_size
    while limit is None or n < limit:
        start, count = ring.pending()
        if count == 0:
            break
        if limit is not None:
            count = min(count, limit - n)
        for slot in range(start, start + count):
            raw = bytes(ring.data[slot * size : (slot + 1) * size])
            level, iteration, t, name_len, text_len, cut = (
                int.from_bytes(raw[i : i + 8], "little", signed=True) for i in range(0, 48, 8)
            )
            name_end = _HEADER + name_len
            rec.level = level
            rec.iteration = iteration
            rec.time_ns = t
            rec.logger = raw[_HEADER:name_end].decode("utf-8", "replace")
            text = raw[name_end : name_end + text_len].decode("utf-8", "replace")
            rec.msg = text + " [message cut: longer than a log record]" if cut else text
            rec.args = ()
            sink(rec)
        ring.release(count)
        n += count
    return n


class NonRealtimeLogger:
    """``self.log.nonrt``: immediate logging for configure/start/stop/cleanup.

    The original's ``NON_RT_*`` macros. It never drops a record (it waits for room)
    and so must not run inside the loop: called while the loop runs, it raises.
    """

    __slots__ = ("_emit", "_parent", "_state", "name")

    def __init__(
        self,
        parent: ComponentLogger,
        state: LoopState,
        emit: Callable[[int, str, str, int, int], None],
    ) -> None:
        self.name = parent.name
        self._parent = parent
        self._state = state
        self._emit = emit

    def log(self, level: int, msg: str, *args: Any) -> None:
        s = self._state
        if s.running:
            raise RtcfError(
                f"{self.name}: self.log.nonrt.{_LEVEL_NAMES.get(level, 'log')}() was called "
                "while the loop runs; it may block. Use self.log."
                f"{_LEVEL_NAMES.get(level, 'info')}() in update()"
            )
        if level >= self._parent.level:
            self._emit(level, self.name, format_message(msg, args), s.iteration, s.time_ns)

    def debug(self, msg: str, *args: Any) -> None:
        self.log(10, msg, *args)

    def info(self, msg: str, *args: Any) -> None:
        self.log(20, msg, *args)

    def warning(self, msg: str, *args: Any) -> None:
        self.log(30, msg, *args)

    warn = warning

    def error(self, msg: str, *args: Any) -> None:
        self.log(40, msg, *args)

    def fatal(self, msg: str, *args: Any) -> None:
        self.log(50, msg, *args)


_LEVEL_NAMES = {10: "debug", 20: "info", 30: "warning", 40: "error", 50: "fatal"}


def _to_python_logging(level: int, logger: str, text: str, iteration: int, time_ns: int) -> None:
    logging.getLogger(python_logger_name(logger)).log(min(level, logging.CRITICAL), "%s", text)


class ComponentLogger:
    """``self.log`` of a component: debug/info/warning/error/fatal, safe in ``update``.

    ``self.log.nonrt`` logs at once and never drops, for the phases outside the loop.
    """

    __slots__ = ("_ring", "_state", "level", "name", "nonrt")

    def __init__(
        self,
        name: str,
        ring: RecordSink,
        state: LoopState,
        level: int = LogLevel.INFO,
        emit: Callable[[int, str, str, int, int], None] | None = None,
    ):
        self.name = name
        self._ring = ring
        self._state = state
        self.level = int(level)
        self.nonrt = NonRealtimeLogger(self, state, emit or _to_python_logging)

    def log(self, level: int, msg: str, *args: Any) -> None:
        if level >= self.level:
            s = self._state
            self._ring.push(level, self.name, msg, args, s.iteration, s.time_ns)

    def debug(self, msg: str, *args: Any) -> None:
        if self.level <= 10:
            s = self._state
            self._ring.push(10, self.name, msg, args, s.iteration, s.time_ns)

    def info(self, msg: str, *args: Any) -> None:
        if self.level <= 20:
            s = self._state
            self._ring.push(20, self.name, msg, args, s.iteration, s.time_ns)

    def warning(self, msg: str, *args: Any) -> None:
        if self.level <= 30:
            s = self._state
            self._ring.push(30, self.name, msg, args, s.iteration, s.time_ns)

    warn = warning

    def error(self, msg: str, *args: Any) -> None:
        if self.level <= 40:
            s = self._state
            self._ring.push(40, self.name, msg, args, s.iteration, s.time_ns)

    def fatal(self, msg: str, *args: Any) -> None:
        s = self._state
        self._ring.push(50, self.name, msg, args, s.iteration, s.time_ns)

    def set_level(self, level: int | str) -> None:
        self.level = int(LogLevel[level.upper()]) if isinstance(level, str) else int(level)


def python_logger_name(component: str) -> str:
    """Python logger name for a component full name: '/ns/comp' -> 'rtcf.ns.comp'."""
    return "rtcf." + ".".join(p for p in component.split("/") if p)


class PythonLoggingSink:
    """Formats drained records and hands them to Python's ``logging``."""

    def __init__(self) -> None:
        self._loggers: dict[str, logging.Logger] = {}

    def __call__(self, rec: LogRecord) -> None:
        logger = self._loggers.get(rec.logger)
        if logger is None:
            logger = self._loggers[rec.logger] = logging.getLogger(python_logger_name(rec.logger))
        level = logging.CRITICAL if rec.level >= LogLevel.FATAL else rec.level
        if logger.isEnabledFor(level):
            logger.log(
                level,
                "%s",
                rec.format(),
                extra={"rtcf_component": rec.logger, "rtcf_iteration": rec.iteration},
            )
