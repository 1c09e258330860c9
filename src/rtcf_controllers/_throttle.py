"""A problem logged once per occurrence, at most once per interval of the loop's time.

A controller refuses bad input as it arrives (a ``~/commands`` of the wrong length, a
state array of the wrong size) and says so each time; a publisher that repeats the
mistake at 1 kHz would flood the log ring, so further records within ``interval``
seconds are counted instead and the count rides on the next record (as
``RCLCPP_ERROR_THROTTLE`` does, plus the count). Time is the component's, so a run on
the simulated clock logs the same records every time.
"""

from __future__ import annotations

from typing import Any

import rtcf


class Throttled:
    """``error``/``warning`` for one kind of problem of one component, safe in ``update``."""

    __slots__ = ("_component", "_interval_ns", "_last_ns", "_left_out")

    def __init__(self, component: rtcf.Component, interval: float = 1.0) -> None:
        self._component = component
        self._interval_ns = round(interval * 1e9)
        self._last_ns: int | None = None  # when it last logged (None: never)
        self._left_out = 0

    def error(self, msg: str, *args: Any) -> None:
        self._log(40, msg, args)

    def warning(self, msg: str, *args: Any) -> None:
        self._log(30, msg, args)

    def _log(self, level: int, msg: str, args: tuple[Any, ...]) -> None:
        now = self._component.time_ns
        last = self._last_ns
        # a new run starts its time at 0 again: a time before the last record logs
        if last is not None and 0 <= now - last < self._interval_ns:
            self._left_out += 1
            return
        self._last_ns = now
        left_out, self._left_out = self._left_out, 0
        if left_out:
            msg = msg + " (and %d times more since the last such record)"
            args = (*args, left_out)
        self._component.log.log(level, msg, *args)
