"""The supervisor's view of its worker's hardware (the resource manager lives in the worker).

The worker says what hardware it built in its answer to ``hello`` (each hardware's
``list_hardware_components`` fields, rtcf._core._hardware_loop's ``summary``). From then
on each change of a hardware's state reaches the supervisor as a lifecycle outcome of
``@hardware/<name>`` on the outcome ring (a ``set_hardware_component_state`` asked for
here, or a read or write that failed in the loop), so the supervisor answers
``list_hardware_components`` and ``list_hardware_interfaces`` without asking the worker,
and the loop is never stopped for it: an interface is available while its hardware is
configured (inactive or active), claimed while an active controller's command
interfaces name it. ``set_hardware_component_state`` crosses as an update record and is
applied between two iterations, as a controller's lifecycle transition is.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from .._core._hardware_loop import HARDWARE_PREFIX
from .._core._lifecycle import ACTIVE, INACTIVE, STATE_LABELS, SUCCESS, TransitionOutcome
from ._admission import Admission
from ._updates import WorkerUpdates, change_states


class HardwareView:
    """What a worker said of its hardware (``summary``), kept up to date by the outcomes
    its supervisor hears (``listeners``): given what it needs of the supervisor, not the
    supervisor itself."""

    def __init__(self, summary: list[dict[str, Any]],
                 listeners: list[Callable[[str, TransitionOutcome], None]],
                 admission: Admission, updates: WorkerUpdates, hand_over: Callable[[], None],
                 introspect: Callable[[], dict[str, Any]]) -> None:
        self._admission = admission
        self._updates = updates
        self._hand_over = hand_over
        self._introspect = introspect
        self._lock = threading.Lock()
        self.components = {str(c["name"]): dict(c) for c in summary}
        listeners.append(self._heard)

    def __bool__(self) -> bool:
        return bool(self.components)

    def _heard(self, name: str, outcome: TransitionOutcome) -> None:
        if not name.startswith(HARDWARE_PREFIX):
            return
        with self._lock:
            component = self.components.get(name.removeprefix(HARDWARE_PREFIX))
            if component is not None:
                component["state"] = outcome.end

    def set_state(self, name: str, target: int | str,
                  timeout: float = 10.0) -> tuple[bool, int, str]:
        """``set_hardware_component_state``: (ok, the state's id, its label); applied by
        the loop between two iterations (or by the worker between runs)."""
        self._admission.refuse_if_locked("hardware state changes")
        outcome = change_states(
            [(self._updates, self._hand_over, HARDWARE_PREFIX + name, str(target))],
            timeout)[0]
        return outcome.result == SUCCESS, outcome.end, STATE_LABELS.get(outcome.end, "unknown")

    def claimed(self) -> set[str]:
        """The command interfaces the active controllers claim."""
        out: set[str] = set()
        for info in self._introspect().get("components", []):
            if info.get("lifecycle") == "active":
                out.update(info.get("interfaces", ((), ()))[0])
        return out

    def list_components(self) -> list[dict[str, Any]]:
        """``list_hardware_components``: each hardware's fields, its state as (id, label),
        its interfaces as (name, data type, available, claimed)."""
        claimed = self.claimed()
        with self._lock:
            components = [dict(c) for c in self.components.values()]
        for c in components:
            available = c["state"] in (INACTIVE, ACTIVE)
            c["state"] = (c["state"], STATE_LABELS.get(c["state"], "unknown"))
            for kind in ("command_interfaces", "state_interfaces"):
                c[kind] = [(n, t, available, kind == "command_interfaces" and available
                            and n in claimed) for n, t in c[kind]]
        return components

    def list_interfaces(self) -> tuple[list[tuple[str, str, bool, bool]],
                                       list[tuple[str, str, bool, bool]]]:
        """``list_hardware_interfaces``: (command, state) interfaces, each sorted by name."""
        components = self.list_components()
        return tuple(  # type: ignore[return-value]
            sorted((i for c in components for i in c[kind]), key=lambda i: i[0])
            for kind in ("command_interfaces", "state_interfaces"))
