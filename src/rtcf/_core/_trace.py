"""``--trace``: every output topic's value after every iteration, written to CSV.

For debugging and for simulated runs (the trace of a ``--sim`` run is the same,
byte for byte, run after run). Recording appends a row per iteration in the loop,
so it costs time and memory there: do not trace a real-time run you measure.
"""

from __future__ import annotations

import csv
from typing import Any

from ._component import Component
from ._loop_state import LoopState
from ._ports import Slot


class Trace:
    """``visible``: slots to sample instead of a port's own (what the other lanes see
    of a lane on logical execution time: its values of the window, not of its run)."""

    def __init__(
        self,
        components: dict[str, Component],
        state: LoopState,
        visible: dict[str, Slot] | None = None,
    ) -> None:
        ports = sorted(
            (p for c in components.values() for p in c.outputs.values()), key=lambda p: p.topic
        )
        self.topics = [p.topic for p in ports]
        shown = visible or {}
        self._slots = [shown.get(p.topic, p._slot) for p in ports]
        self._state = state
        self.rows: list[list[Any]] = []

    def sample(self) -> None:
        s = self._state
        self.rows.append([s.iteration, s.time_ns, *(slot.value for slot in self._slots)])

    def write(self, path: str) -> None:
        with open(path, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["iteration", "time_ns", *self.topics])
            for row in self.rows:
                out.writerow([row[0], row[1], *(_cell(v) for v in row[2:])])


def _cell(value: Any) -> str:
    return "" if value is None else repr(value) if isinstance(value, float) else str(value)
