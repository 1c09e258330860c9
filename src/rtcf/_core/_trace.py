"""``--trace``: every output topic's value after every iteration, written to CSV.

For debugging and for simulated runs (the trace of a ``--sim`` run is the same,
byte for byte, run after run). Recording appends a row per iteration in the loop,
so it costs time and memory there: do not trace a real-time run you measure.
"""

from __future__ import annotations

import csv
from typing import Any

from ._cdr import Serialized
from ._component import Component
from ._loop_state import LoopState
from ._ports import Slot


class Trace:
    """``visible``: slots to sample instead of a port's own (what the other lanes see
    of a lane on logical execution time: its values of the window, not of its run).
    ``foreign``: the topics of the other lanes' processes, as the main lane receives
    them."""

    def __init__(
        self,
        components: dict[str, Component],
        state: LoopState,
        visible: dict[str, Slot] | None = None,
        foreign: dict[str, Slot] | None = None,
    ) -> None:
        shown = visible or {}
        columns = [
            (p.topic, shown.get(p.topic, p._slot))
            for c in components.values()
            for p in c.outputs.values()
        ]
        columns += sorted((foreign or {}).items())
        columns.sort(key=lambda c: c[0])
        self.topics = [t for t, _ in columns]
        self._slots = [s for _, s in columns]
        self._state = state
        self.rows: list[list[Any]] = []

    def sample(self) -> None:
        s = self._state
        self.rows.append([s.iteration, s.time_ns, *(_kept(slot.value) for slot in self._slots)])

    def write(self, path: str) -> None:
        with open(path, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["iteration", "time_ns", *self.topics])
            for row in self.rows:
                out.writerow([row[0], row[1], *(_cell(v) for v in row[2:])])


def _kept(value: Any) -> Any:
    """A value as it was now: a Serialized is rewritten in place by its writer, so the
    trace keeps its message."""
    return value.to_message() if type(value) is Serialized else value


def _cell(value: Any) -> str:
    return "" if value is None else repr(value) if isinstance(value, float) else str(value)
