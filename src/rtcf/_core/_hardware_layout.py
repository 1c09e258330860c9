"""Where a hardware component's interface values live: one float64 array per direction.

A hardware component exports state and command interfaces (ros2_control's
``InterfaceDescription``: a prefix, a joint, sensor or GPIO name, and an interface
name: ``joint1/position``). ros2_control gives each one a handle of its own; rtcf puts
all the states of one hardware in one float64 array and all its commands in another,
so that the loop moves values by index, with no allocation, and a resource manager can
place every hardware's arrays in one buffer as slices of it (:class:`Layout`).

The order within a hardware's arrays is rtcf's (ros2_control keeps them in hash maps,
in no order): joints first, grouped by interface name (all ``position`` states, in the
order of the joints that have one, then all ``velocity`` states, ...), so that one
interface of all joints is a contiguous slice; then each sensor's interfaces, then each
GPIO's, each contiguous; then the interfaces whose prefix is none of these (a
hardware's own, "unlisted" ones), in the order it exported them.

Every value is a float64, whatever the interface's ``data_type``: ``double`` and
``float32`` as they are (a ``float32`` initial value rounded to float32), ``bool`` as
0.0 or 1.0, the integer types as their integer value. Initial values are those of
ros2_control's handles: the ``initial_value`` parameter, otherwise NaN for ``double``
and ``float32``, false for ``bool`` and the type's largest value for the integer types.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._errors import ConfigurationError
from ._robot_description import HardwareInfo, InterfaceInfo, _as_bool, _as_float

_INT_RANGES = {
    "uint8": (0, 2**8 - 1), "int8": (-(2**7), 2**7 - 1),
    "uint16": (0, 2**16 - 1), "int16": (-(2**15), 2**15 - 1),
    "uint32": (0, 2**32 - 1), "int32": (-(2**31), 2**31 - 1),
}
DATA_TYPES = ("double", "float32", "bool", *_INT_RANGES)


@dataclass(frozen=True)
class InterfaceDescription:
    """One exported interface (ros2_control's ``InterfaceDescription``): ``name`` is
    ``"<prefix_name>/<interface_name>"``, e.g. ``joint1/position``."""

    prefix_name: str
    interface_info: InterfaceInfo

    @property
    def interface_name(self) -> str:
        return self.interface_info.name

    @property
    def name(self) -> str:
        return f"{self.prefix_name}/{self.interface_info.name}"

    @property
    def data_type(self) -> str:
        return self.interface_info.data_type


def describe(prefix: str, interface: str | InterfaceInfo, **info: object) -> InterfaceDescription:
    """An interface description: ``describe("ft", "temperature")`` or with an
    :class:`InterfaceInfo`'s fields (``data_type="bool"``, ``initial_value="0.5"``)."""
    if isinstance(interface, InterfaceInfo):
        return InterfaceDescription(prefix, interface)
    return InterfaceDescription(prefix, InterfaceInfo(name=interface, **info))  # type: ignore[arg-type]


def initial_value(description: InterfaceDescription) -> float:
    """The value an interface starts with, as ros2_control's ``Handle`` sets it."""
    data_type = description.data_type
    text = description.interface_info.initial_value.strip()
    if data_type not in DATA_TYPES:
        raise ConfigurationError(
            f"Invalid data type: '{data_type}' for interface: {description.name}. Check "
            f"supported types ({', '.join(DATA_TYPES)}).")
    try:
        if data_type in ("double", "float32"):
            if not text:
                return math.nan
            value = _as_float(text)
            return float(np.float32(value)) if data_type == "float32" else value
        if data_type == "bool":
            return float(_as_bool(text)) if text else 0.0
        low, high = _INT_RANGES[data_type]
        if not text:
            return float(high)
        number = int(text)
        if not low <= number <= high:
            raise ValueError(text)
        return float(number)
    except ValueError:
        raise ConfigurationError(
            f"Invalid initial value : '{text}' parsed for interface : '{description.name}' "
            f"with type : '{data_type}'") from None


@dataclass(frozen=True)
class Layout:
    """The order of one direction's (states' or commands') values, and its groups.

    ``names[i]`` is the interface whose value is ``array[i]``; ``index`` maps a name to
    its position; ``groups`` maps ``(kind, key)`` to a slice: ``("joint", "position")``
    is the position interfaces of the joints that have one, ``("sensor", "ft")`` and
    ``("gpio", "io")`` a sensor's or GPIO's interfaces; ``members`` the prefixes (joint
    names) or interface names in each group, in order."""

    descriptions: tuple[InterfaceDescription, ...]
    names: tuple[str, ...]
    index: Mapping[str, int]
    data_types: tuple[str, ...]
    initial: tuple[float, ...]
    groups: Mapping[tuple[str, str], slice] = field(default_factory=dict)
    members: Mapping[tuple[str, str], tuple[str, ...]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.names)


def layout(info: HardwareInfo, exported: Iterable[InterfaceDescription], what: str) -> Layout:
    """The layout of ``exported`` (a hardware's exported states or commands) in rtcf's
    order; ``what`` ("state" or "command") for the error of a name exported twice."""
    kinds = {c.name: "joint" for c in info.joints}
    for kind, components in (("sensor", info.sensors), ("gpio", info.gpios)):
        for c in components:
            kinds.setdefault(c.name, kind)
    buckets: dict[tuple[str, str], list[InterfaceDescription]] = {}
    seen: set[str] = set()
    for description in exported:
        if description.name in seen:
            raise ConfigurationError(
                f"hardware '{info.name}': ResourceStorage: Tried to insert "
                f"{what.capitalize()}Interface with already existing key. "
                f"Insert[{description.name}]")
        seen.add(description.name)
        kind = kinds.get(description.prefix_name, "other")
        key = description.interface_name if kind == "joint" else description.prefix_name
        buckets.setdefault((kind, "" if kind == "other" else key), []).append(description)
    ordered: list[InterfaceDescription] = []
    groups: dict[tuple[str, str], slice] = {}
    members: dict[tuple[str, str], tuple[str, ...]] = {}
    for kind in ("joint", "sensor", "gpio", "other"):
        for (k, key), descriptions in buckets.items():
            if k != kind:
                continue
            start = len(ordered)
            ordered.extend(descriptions)
            if kind != "other":
                groups[(kind, key)] = slice(start, len(ordered))
                members[(kind, key)] = tuple(
                    d.prefix_name if kind == "joint" else d.interface_name for d in descriptions)
    names = tuple(d.name for d in ordered)
    return Layout(
        descriptions=tuple(ordered), names=names,
        index={name: i for i, name in enumerate(names)},
        data_types=tuple(d.data_type for d in ordered),
        initial=tuple(initial_value(d) for d in ordered), groups=groups, members=members)


def checked_values(values: np.ndarray | None, size: int, what: str, hardware: str) -> np.ndarray:
    """``values`` if it can hold ``size`` values in place (a 1-D float64 array of that
    length, possibly a view into a larger buffer), a new array if None."""
    if values is None:
        return np.full(size, math.nan)
    if not isinstance(values, np.ndarray) or values.dtype != np.float64 or values.shape != (
            size,):
        shape = getattr(values, "shape", None)
        dtype = getattr(values, "dtype", type(values).__name__)
        raise ValueError(
            f"hardware '{hardware}': the {what} array must be a 1-D float64 numpy array of "
            f"{size} values (got {dtype} of shape {shape})")
    return values


def descriptions_of(components: Sequence, which: str) -> list[InterfaceDescription]:
    """The descriptions of ``components``' ``which`` ("state_interfaces" or
    "command_interfaces"), the first of a name where one is listed twice (as
    ros2_control's maps keep them)."""
    found: dict[str, InterfaceDescription] = {}
    for component in components:
        for interface in getattr(component, which):
            description = InterfaceDescription(component.name, interface)
            found.setdefault(description.name, description)
    return list(found.values())
