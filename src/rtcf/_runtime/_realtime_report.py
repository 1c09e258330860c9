"""The report of the real-time settings: what was asked for, what took effect, and why not.

:func:`._realtime.apply_realtime` fills it, :class:`._realtime.FrozenGC` adds its
``gc`` item, and the worker sends it to the supervisor, which writes it as the
``realtime`` section of timing.json and prints :func:`describe_failures` at start.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from .._core import _hotpath

SIMULATED = "simulated clock (--sim)"


@dataclass
class Applied:
    """One setting: what was asked for, whether it took effect, and what happened."""

    name: str
    requested: str
    ok: bool
    detail: str


@dataclass
class RealtimeReport:
    """What :func:`apply_realtime` did, with the state read back from the kernel."""

    items: list[Applied]
    scheduler: str
    priority: int | None
    cpu_affinity: list[int]
    mlockall: bool
    kernel_preemption: str
    rt_throttling: str
    simulated: bool = False

    @property
    def not_applied(self) -> list[Applied]:
        return [item for item in self.items if not item.ok]

    def item(self, name: str) -> Applied | None:
        return next((i for i in self.items if i.name == name), None)

    def to_dict(self) -> dict[str, Any]:
        """The ``realtime`` section of timing.json."""
        gc_item = self.item("gc")
        if gc_item is None:
            gc_text = "left as is (FrozenGC not used)"
        else:
            gc_text = gc_item.detail if gc_item.ok else f"not applied: {gc_item.detail}"
        return {
            "scheduler": self.scheduler,
            "priority": self.priority,
            "mlockall": self.mlockall,
            "cpu_affinity": list(self.cpu_affinity),
            "kernel_preemption": self.kernel_preemption,
            "rt_throttling": self.rt_throttling,
            "gc": gc_text,
            "applied": [asdict(i) for i in self.items],
            # which hot path this process's loop runs: compiled, or Python and why
            "hot_path": {"path": _hotpath.HOT_PATH, "why": _hotpath.WHY,
                         # what times each component: the TSC, or clock_gettime
                         "component_clock": _hotpath.component_clock()[0]},
        }

    def lines(self) -> list[str]:
        """One short line per setting, for the start-up log."""
        return [
            f"{i.name}: {i.requested}: applied" if i.ok else f"{i.name}: not applied: {i.detail}"
            for i in self.items
        ]


def describe_failures(report: RealtimeReport) -> str | None:
    """One sentence for the start-up banner on what did not take effect (None: all did)."""
    failed = report.not_applied
    if not failed:
        return None
    if all(i.detail == SIMULATED for i in failed):
        return "simulated clock (--sim): no real-time settings applied; timing is not measured"
    parts = [f"{i.name} ({_first_clause(i.detail)})" for i in failed]
    return (
        "real-time settings not in effect: "
        + ", ".join(parts)
        + "; expect more jitter than the machine can deliver"
    )


def _first_clause(text: str) -> str:
    """Text up to the first ``; `` outside parentheses: the reason without the aftermath."""
    depth = 0
    for n, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(0, depth - 1)
        elif ch == ";" and depth == 0:
            return text[:n]
    return text
