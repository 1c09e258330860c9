"""Real-time safe logging: records go into a preallocated ring, formatted later.

Calling ``self.log.info("x=%s", x)`` from ``update`` stores the level, the format
string and the argument tuple in a slot that already exists; nothing is formatted
and no I/O happens in the loop. The records are formatted and handed to Python's
``logging`` (and later to ROS) outside the loop. When the ring is full the record
is dropped and counted; the count is reported, never hidden.

Arguments are formatted when the record is drained, so pass values that will not
change afterwards (numbers, strings, tuples), not an array you mutate in place.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Callable
from typing import Any

from ._loop_state import LoopState


class LogLevel(enum.IntEnum):
    DEBUG = 10
    INFO = 20
    WARNING = 30
    ERROR = 40
    FATAL = 50


class LogRecord:
    """One slot of the ring (reused, never reallocated)."""

    __slots__ = ("args", "iteration", "level", "logger", "msg", "time_ns")

    def __init__(self) -> None:
        self.level = 0
        self.logger = ""
        self.msg = ""
        self.args: tuple[Any, ...] = ()
        self.iteration = -1
        self.time_ns = 0

    def format(self) -> str:
        if not self.args:
            return str(self.msg)
        try:
            return str(self.msg) % self.args
        except (TypeError, ValueError) as exc:
            return f"{self.msg!r} % {self.args!r} (bad log format: {exc})"


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


class ComponentLogger:
    """``self.log`` of a component: debug/info/warning/error/fatal, safe in ``update``."""

    __slots__ = ("_ring", "_state", "level", "name")

    def __init__(self, name: str, ring: LogRing, state: LoopState, level: int = LogLevel.INFO):
        self.name = name
        self._ring = ring
        self._state = state
        self.level = int(level)

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
