"""Controllers' reference interfaces in the resource manager's key space.

A chainable controller (rtcf._core._chaining) exports reference interfaces named
``<controller>/<key>`` (``pid_left/left_wheel_joint/velocity``). As ros2_control's
resource manager imports a controller's reference interfaces as handles to the
controller's own storage (``import_controller_reference_interfaces``), rtcf's keeps,
per key, the controller's float64 array and the value's place in it: a preceding
controller that claims the key writes there (``np.put``, no allocation), and the
controller reads the very array in its update. The values stay the controller's, so
loading or unloading controllers rebuilds this table (between iterations, when the
schedule is compiled) and never moves a value.

The keys are command interfaces like the hardware's: they exist from the controller's
configure and are *available* while it is active (ros2_control makes them available
on activation, unavailable on deactivation); claims take them with the hardware's.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

import numpy as np


class Reference(NamedTuple):
    """One reference interface: its controller (full name), its array and place."""

    controller: str
    values: np.ndarray
    place: int


class ControllerReferences:
    """Every loaded chainable controller's reference interfaces, by full key."""

    def __init__(self) -> None:
        self._by_key: dict[str, Reference] = {}
        self._by_controller: dict[str, tuple[str, ...]] = {}
        self._available: set[str] = set()  # controllers whose references are available

    def __contains__(self, key: object) -> bool:
        return key in self._by_key

    def keys(self) -> tuple[str, ...]:
        return tuple(self._by_key)

    def import_controller(self, controller: str, keys: Iterable[str], values: np.ndarray) -> str:
        """Import ``controller``'s references (``keys[i]`` is ``values[i]``): "" if done,
        else why not (a key another controller exports)."""
        keys = tuple(keys)
        if self._by_controller.get(controller) == keys and keys and (
                self._by_key[keys[0]].values is values):
            return ""  # imported already (its availability stays)
        for key in keys:
            known = self._by_key.get(key)
            if known is not None and known.controller != controller:
                return (f"ResourceStorage: Tried to insert CommandInterface with already "
                        f"existing key. Insert[{key}] (controller '{known.controller}' exports "
                        "it too)")
        self.remove_controller(controller)
        for i, key in enumerate(keys):
            self._by_key[key] = Reference(controller, values, i)
        self._by_controller[controller] = keys
        return ""

    def remove_controller(self, controller: str) -> None:
        for key in self._by_controller.pop(controller, ()):
            del self._by_key[key]
        self._available.discard(controller)

    def controllers(self) -> tuple[str, ...]:
        return tuple(self._by_controller)

    def keys_of(self, controller: str) -> tuple[str, ...]:
        return self._by_controller.get(controller, ())

    def set_available(self, controller: str, available: bool) -> None:
        """ros2_control's ``make_controller_reference_interfaces_(un)available``."""
        if available and controller in self._by_controller:
            self._available.add(controller)
        else:
            self._available.discard(controller)

    def owner(self, key: str) -> str:
        """The controller that exports ``key`` ("" if none)."""
        ref = self._by_key.get(key)
        return ref.controller if ref is not None else ""

    def get(self, key: str) -> Reference | None:
        return self._by_key.get(key)

    def is_available(self, key: str) -> bool:
        ref = self._by_key.get(key)
        return ref is not None and ref.controller in self._available
