"""Which hot path runs: the compiled one (``_compiled*.c``) or the same in Python.

The compiled module is built when rtcf is installed with a C compiler at hand. Where
it is missing, the loop runs the Python one (``_interpreted.py``), and ``rtcf launch``
says so once (from the worker's ``realtime.hot_path``);
``RTCF_PURE_PYTHON=1`` asks for the Python one. Both give the same values; the
compiled one costs a fraction per component (docs/performance.md#the-hot-path-in-c).
"""

from __future__ import annotations

import os
from array import array
from typing import TYPE_CHECKING, Any

from . import _interpreted

_module: Any = _interpreted
#: "compiled" or "Python"; and, for Python, why (empty when compiled)
HOT_PATH = "Python"
WHY = ""
FORCED = "RTCF_PURE_PYTHON is set"  # the why of a Python path asked for: no warning
if os.environ.get("RTCF_PURE_PYTHON", "") not in ("", "0"):
    WHY = FORCED
else:
    try:
        from . import _compiled  # type: ignore[attr-defined]
    except ImportError:
        WHY = (
            "rtcf._core._compiled was not built when rtcf was installed (no C compiler?): "
            "install gcc and python3-dev, then reinstall rtcf"
        )
    else:
        _module = _compiled
        HOT_PATH = "compiled"

if TYPE_CHECKING:  # the two have the same API: type-check against the Python one
    from ._interpreted import (
        Calculation,
        CommandCheck,
        CompiledPlans,
        DeadlineGate,
        Handover,
        HeartbeatWatch,
        InputPort,
        LoopState,
        OutputPort,
        Port,
        RingGate,
        Slot,
        WordTap,
        set_flow_status,
    )
else:
    Slot = _module.Slot
    LoopState = _module.LoopState
    Port = _module.Port
    OutputPort = _module.OutputPort
    InputPort = _module.InputPort
    Calculation = _module.Calculation
    CompiledPlans = _module.CompiledPlans
    RingGate = _module.RingGate
    HeartbeatWatch = _module.HeartbeatWatch
    DeadlineGate = _module.DeadlineGate
    WordTap = _module.WordTap  # None on the Python path
    Handover = _module.Handover  # None on the Python path
    CommandCheck = _module.CommandCheck
    set_flow_status = _module.set_flow_status


def gate_words(values: list[int]) -> Any:
    """The per-input words a DeadlineGate of this path keeps (its seqs, its due
    times): int64 words for the compiled one, a list (no boxing) for the Python one."""
    return array("q", values) if HOT_PATH == "compiled" else list(values)


def describe() -> str:
    """One phrase for the run's report: which path, and why Python if it is."""
    return "compiled (C)" if HOT_PATH == "compiled" else f"Python ({WHY})"



_CLOCKSOURCE = "/sys/devices/system/clocksource/clocksource0/current_clocksource"
_component_clock: tuple[str, float] | None = None


def component_clock() -> tuple[str, float]:
    """What times each component in a loop on CLOCK_MONOTONIC: ("TSC", ns per cycle)
    on the compiled path where the kernel's clocksource is the TSC (it then trusts it to
    be invariant and synchronised across CPUs), read for 10 ns rather than 25 ns for
    clock_gettime; else ("CLOCK_MONOTONIC", 0.0). The iteration's own start and end
    stay on CLOCK_MONOTONIC. Measured once per process (2 ms, outside any loop);
    ``RTCF_COMPONENT_CLOCK=monotonic`` keeps clock_gettime."""
    global _component_clock
    if _component_clock is None:
        _component_clock = ("CLOCK_MONOTONIC", 0.0)
        wanted = os.environ.get("RTCF_COMPONENT_CLOCK", "").lower()
        if HOT_PATH == "compiled" and wanted not in ("monotonic", "clock_monotonic"):
            try:
                with open(_CLOCKSOURCE) as f:
                    source = f.read().strip()
            except OSError:
                source = ""
            if source == "tsc":
                per_cycle = float(_module.ns_per_cycle())
                if per_cycle > 0.0:
                    _component_clock = ("TSC", per_cycle)
    return _component_clock
