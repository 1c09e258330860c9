"""What the supervisor knows of the components its worker(s) hold, as tools see them.

One entry per loaded component (its type, ports, parameters, tunables and their
current values, log level, lifecycle state as last reported) and the introspection
data (the order and the graph over all lanes) that the bridges' services read. The
bridge's threads read them while the main thread loads, unloads and refreshes: every
change is made under the runner's lock (shared with the updates to the worker, whose
answers change the lifecycle states here).
"""

from __future__ import annotations

import threading
from typing import Any

from .._core._errors import RtcfError
from .._core._tunables import TunableSpec


class LoadedComponents:
    """The loaded components' entries and the introspection data, under ``lock``."""

    def __init__(self, lock: threading.Lock) -> None:
        self.lock = lock
        # loaded components as tools see them (type, ports, parameters, tunables)
        self.components: dict[str, dict[str, Any]] = {}
        # what the introspection commands show; refreshed by the main thread after
        # loads and unloads, read by the bridge's service (which must not wait on it)
        self.introspection: dict[str, Any] = {}

    def find(self, name: str) -> dict[str, Any]:
        """A loaded component's entry (RtcfError naming the loaded ones if it is not)."""
        full = name if name.startswith("/") else "/" + name
        info = self.components.get(full)
        if info is None:
            known = ", ".join(self.components) or "none"
            raise RtcfError(f"component {full!r} is not loaded (loaded: {known})")
        return info

    def tunable(self, component: str, name: str) -> TunableSpec:
        """The declaration of a loaded component's tunable parameter."""
        info = self.find(component)
        for t in info["tunables"]:
            if t["name"] == name:
                return TunableSpec.from_dict({k: v for k, v in t.items() if k != "value"})
        known = ", ".join(t["name"] for t in info["tunables"]) or "none"
        raise RtcfError(
            f"component {info['name']!r} has no tunable parameter {name!r} (it declares: {known})"
        )

    # -- changes (under the lock) ---------------------------------------------------
    def set_value(self, component: str, name: str, value: Any) -> None:
        for t in self.find(component)["tunables"]:
            if t["name"] == name:
                t["value"] = value

    def replace(self, component: str, info: dict[str, Any]) -> dict[str, Any] | None:
        """A component as the worker describes it now (its first configure declared its
        ports); the entry is updated in place (the main lane's runner holds it too)."""
        with self.lock:
            entry = self.components.get(component)
            if entry is not None:
                entry.update({k: v for k, v in info.items() if k != "launcher"})
        return entry

    def set_lifecycle(self, component: str, label: str) -> None:
        info = self.components.get(component)
        if info is not None:
            info["lifecycle"] = label

    # -- introspection ------------------------------------------------------------
    def publish(self, data: dict[str, Any]) -> None:
        """The introspection data from now on (the main thread, after a refresh)."""
        with self.lock:
            self.introspection = data

    def introspect(self) -> dict[str, Any]:
        """The last introspection data, with the current tunable values and log levels."""
        with self.lock:
            data = dict(self.introspection)
            data["components"] = [
                self.components.get(c["name"], c) for c in data.get("components", [])
            ]
        return data
