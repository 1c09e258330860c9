"""What a runner tells outside its loop: its own log records, and the hook about to run.

The runner's own records (lifecycle outcomes, faults, safe stops) and its components'
``self.log.nonrt`` records are written at once, after what the ring holds, so that
they come out in order with the records the loop made. A worker passes its ring in
shared memory and an ``emit`` of its own instead (its supervisor drains them). The
observer is told of each hook a runner calls outside the loop (``configure``,
``start``, ``safe_stop``, ...): a worker passes it on, so that its supervisor can name
a hook that hangs.

Held apart from the runner because the loading, the lifecycle transitions, the fault
containment and the teardown all tell through it.
"""

from __future__ import annotations

from collections.abc import Callable

from ._log import LogRecord, LogRing, RecordSink
from ._loop_state import LoopState

Emit = Callable[[int, str, str, int, int], None]  # level, logger, text, iteration, time_ns


class Notices:
    """A runner's log ring and sink, how its records are written, and its hook observer."""

    def __init__(
        self,
        state: LoopState,
        ring: RecordSink,
        sink: Callable[[LogRecord], None],
        emit: Emit | None = None,
    ) -> None:
        self.state = state
        self.ring = ring
        self.sink = sink
        self.emit: Emit = emit or self._emit_now
        # told (component, hook) before a hook outside the loop runs, ("", "") after
        self.observer: Callable[[str, str], None] | None = None

    def drain(self) -> int:
        ring = self.ring
        return ring.drain(self.sink) if isinstance(ring, LogRing) else 0

    def log(self, level: int, logger: str, text: str) -> None:
        """A record stamped with the loop's current iteration and time."""
        s = self.state
        self.emit(level, logger, text, s.iteration, s.time_ns)

    def observe(self, component: str, hook: str) -> None:
        if self.observer is not None:
            self.observer(component, hook)

    def _emit_now(self, level: int, logger: str, text: str, iteration: int, time_ns: int) -> None:
        """Non-real-time logging in this process: after what the ring holds, in order."""
        self.drain()
        self.sink(LogRecord(level, logger, text, iteration, time_ns))
