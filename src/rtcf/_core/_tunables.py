"""Tunable parameters: values that tools change while the loop runs.

A component declares them in ``configure``::

    self.gain = self.params.declare("gain", 2.0, description="output per input",
                                    min=0.0, max=10.0)

and reads ``self.gain.value`` in ``update``. A change (ROS 2 ``set_parameters``,
ROS 1 ``dynparam set``) is validated by the supervisor against the declaration,
crosses to the worker as one record of a shared ring, and is applied at the start
of an iteration, never during one: every ``update`` of an iteration sees the same
value, and the component sees the new one from the next ``update`` on (the
original's real-time dynamic_reconfigure wrapper). ``version`` counts the changes,
so a component can recompute what depends on a value only when it changed.

Log levels travel the same way, so that a level set by ``set_logger_levels``
filters records in the worker, before they take room in the log ring, and so do
lifecycle transitions (``_lifecycle``): the record names the transition and carries
the request's number, and the worker answers on a ring of outcomes.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any, Generic, Protocol, TypeVar

from ._errors import ConfigurationError
from ._hotpath import RingGate

T = TypeVar("T")

TYPES: dict[str, type] = {"bool": bool, "int": int, "float": float, "str": str}

# what an update record is about
PARAMETER = 1
LOG_LEVEL = 2
LIFECYCLE = 3  # name: the transition (label or id); value: the request's number
# a STRICT switch (all or nothing in one iteration): value: how many LIFECYCLE records
# follow it, in the same ring commit (rtcf._runtime._worker_updates)
BATCH = 4

UPDATE_RECORD_SIZE = 1024  # bytes of one record of the update ring (a long str must fit)
UPDATE_RING_RECORDS = 64
_HEAD = struct.Struct("<BBHHH")  # kind, value type, len(component), len(name), len(value)
_TYPE_CODES = {"bool": 1, "int": 2, "float": 3, "str": 4}
_CODE_TYPES = {v: k for k, v in _TYPE_CODES.items()}


@dataclass(frozen=True)
class TunableSpec:
    """A tunable parameter's declaration: what the supervisor validates against."""

    component: str
    name: str
    type: str  # "bool", "int", "float" or "str"
    default: Any
    description: str = ""
    min: float | int | None = None
    max: float | int | None = None
    choices: tuple[Any, ...] | None = None  # an enum: the only values allowed

    def where(self) -> str:
        return f"component {self.component!r}: tunable parameter {self.name!r}"

    def validate(self, value: Any) -> Any:
        """Return ``value`` as this parameter's type, or raise ConfigurationError."""
        kind = self.type
        ok = (
            (kind == "bool" and isinstance(value, bool))
            or (kind == "int" and isinstance(value, int) and not isinstance(value, bool))
            or (kind == "float" and isinstance(value, (int, float)) and not isinstance(value, bool))
            or (kind == "str" and isinstance(value, str))
        )
        if not ok:
            raise ConfigurationError(
                f"{self.where()} is a {kind}; {value!r} ({type(value).__name__}) is not"
            )
        if kind == "float":
            value = float(value)
        if self.choices is not None and value not in self.choices:
            allowed = ", ".join(repr(c) for c in self.choices)
            raise ConfigurationError(f"{self.where()}: {value!r} is not one of {allowed}")
        if self.min is not None and value < self.min:
            raise ConfigurationError(f"{self.where()}: {value!r} is below its minimum {self.min!r}")
        if self.max is not None and value > self.max:
            raise ConfigurationError(f"{self.where()}: {value!r} is above its maximum {self.max!r}")
        if kind == "str" and len(value.encode("utf-8")) > max_text_bytes(self.component, self.name):
            raise ConfigurationError(
                f"{self.where()}: a value of {len(value.encode('utf-8'))} bytes is longer than "
                f"an update record holds ({max_text_bytes(self.component, self.name)} bytes)"
            )
        return value

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["choices"] = list(self.choices) if self.choices is not None else None
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TunableSpec:
        choices = d.get("choices")
        return cls(**{**d, "choices": tuple(choices) if choices is not None else None})


class Tunable(Generic[T]):
    """A tunable parameter as the component sees it: read ``value`` in ``update``."""

    __slots__ = ("spec", "value", "version")

    def __init__(self, spec: TunableSpec, value: T) -> None:
        self.spec = spec
        self.value: T = value
        self.version = 0  # how many times the value was changed while loaded

    @property
    def name(self) -> str:
        return self.spec.name

    def _apply(self, value: T) -> None:
        self.value = value
        self.version += 1

    def __repr__(self) -> str:
        return f"<Tunable {self.spec.component}:{self.spec.name}={self.value!r}>"


def declare(
    component: str,
    name: str,
    default: Any,
    initial: Any,
    *,
    description: str = "",
    min: float | None = None,
    max: float | None = None,
    choices: Sequence[Any] | None = None,
) -> Tunable[Any]:
    """Check a declaration and make its Tunable, valued ``initial`` (validated)."""
    where = f"component {component!r}: tunable parameter {name!r}"
    kind = next((k for k, t in TYPES.items() if type(default) is t), None)
    if kind is None:
        raise ConfigurationError(
            f"{where}: the default {default!r} is a {type(default).__name__}; "
            "a tunable parameter is a bool, int, float or str"
        )
    if (min is not None or max is not None) and kind not in ("int", "float"):
        raise ConfigurationError(f"{where}: min and max apply to int and float parameters only")
    if min is not None and max is not None and min > max:
        raise ConfigurationError(f"{where}: min {min!r} is above max {max!r}")
    spec = TunableSpec(
        component=component,
        name=name,
        type=kind,
        default=default,
        description=description,
        min=min,
        max=max,
        choices=tuple(choices) if choices is not None else None,
    )
    spec.validate(default)
    return Tunable(spec, spec.validate(initial))


def max_text_bytes(component: str, name: str) -> int:
    used = _HEAD.size + len(component.encode()) + len(name.encode())
    return UPDATE_RECORD_SIZE - used


def encode_update(kind: int, component: str, name: str, value: Any) -> bytes:
    """One update record: a tunable's new value, a component's log level, a transition."""
    if kind in (LOG_LEVEL, LIFECYCLE, BATCH):
        vtype, payload = "int", struct.pack("<q", int(value))
    else:
        vtype = next(k for k, t in TYPES.items() if type(value) is t)
        if vtype == "bool":
            payload = b"\x01" if value else b"\x00"
        elif vtype == "int":
            payload = struct.pack("<q", value)
        elif vtype == "float":
            payload = struct.pack("<d", value)
        else:
            payload = value.encode("utf-8")
    c, n = component.encode(), name.encode()
    record = _HEAD.pack(kind, _TYPE_CODES[vtype], len(c), len(n), len(payload)) + c + n + payload
    if len(record) > UPDATE_RECORD_SIZE:
        raise ConfigurationError(
            f"component {component!r}: the update of {name!r} does not fit an update record"
        )
    return record


def decode_update(record: bytes | memoryview) -> tuple[int, str, str, Any]:
    kind, code, lc, ln, lv = _HEAD.unpack_from(record)
    at = _HEAD.size
    component = bytes(record[at : at + lc]).decode()
    at += lc
    name = bytes(record[at : at + ln]).decode()
    at += ln
    payload = bytes(record[at : at + lv])
    vtype = _CODE_TYPES[code]
    value: Any
    if vtype == "bool":
        value = payload != b"\x00"
    elif vtype == "int":
        value = struct.unpack("<q", payload)[0]
    elif vtype == "float":
        value = struct.unpack("<d", payload)[0]
    else:
        value = payload.decode("utf-8")
    return kind, component, name, value


class UpdateReader:
    """Worker side: applies the waiting update records (a feeder: runs between iterations)."""

    __slots__ = ("_apply", "_ring", "applied")

    def __init__(self, ring: Any, apply: Any) -> None:
        self._ring = ring
        self._apply = apply  # apply(kind, component, name, value)
        self.applied = 0

    def gate(self) -> RingGate:
        """This reader as a loop's feeder: called only when a record waits (the common
        case, none, is two shared words read, in C where the hot path is compiled).
        ``release()`` it before the ring closes."""
        return self._ring.when_pending(self)

    def __call__(self) -> None:
        ring = self._ring
        if not len(ring):  # the common case: two shared words read, nothing else
            return
        while True:
            record = ring.pop()
            if record is None:
                return
            self._apply(*decode_update(record))
            self.applied += 1


class Tuner(Protocol):
    """Where changes go: the supervisor's WorkerRunner, or a launcher's link to its runner."""

    def set_parameter(self, component: str, name: str, value: Any) -> Any: ...

    def set_log_level(self, component: str, level: int | str) -> None: ...
