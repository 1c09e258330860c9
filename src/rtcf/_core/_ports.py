"""Ports: typed inputs and outputs of a component, connected through shared slots.

An output owns a :class:`Slot`; every input connected to it holds a reference to
that same slot, so a write is two attribute stores and a read is one look-up: no
copy, no queue, no allocation. Values pass by reference: do not mutate an object
after writing it (write a new one, or a copy).

An input with no producer gets a slot of its own that nothing inside the runner
writes (a middleware bridge may feed it between iterations).
"""

from __future__ import annotations

import enum
from typing import Any, Generic, TypeVar

T = TypeVar("T")


class FlowStatus(enum.IntEnum):
    """What an input holds, as OROCOS tells it: nothing yet, an old value, a new one."""

    NO_DATA = 0
    OLD_DATA = 1
    NEW_DATA = 2


class Slot:
    """The latest value on one topic and how many times it was written."""

    __slots__ = ("iteration", "seq", "value")

    def __init__(self) -> None:
        self.value: Any = None
        self.seq = 0  # number of writes; 0 means never written
        self.iteration = -1  # the loop iteration of the last write (-1: none, or outside)


class _NoLoop:
    iteration = -1


_NO_LOOP = _NoLoop()


class Port(Generic[T]):
    """Common part of inputs and outputs."""

    __slots__ = ("_slot", "component", "name", "topic", "type")

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        self.component = component  # full name of the owning component
        self.name = name  # name given in add_input/add_output
        self.type = type_
        self.topic = ""  # resolved topic name, set when the runner wires the graph
        self._slot = Slot()

    @property
    def qualified_name(self) -> str:
        return f"{self.component}.{self.name}"


class OutputPort(Port[T]):
    """An output port: ``write(value)`` makes ``value`` the topic's latest value."""

    __slots__ = ("_state", "_tap")
    direction = "output"

    def __init__(self, component: str, name: str, type_: type[T], state: Any = None) -> None:
        super().__init__(component, name, type_)
        self._tap: Any = None  # set while the port is mapped to the middleware
        # the loop's state: a write records its iteration (-1 for a port outside a loop)
        self._state = state if state is not None else _NO_LOOP

    def write(self, value: T) -> None:
        slot = self._slot
        slot.value = value
        slot.seq += 1
        slot.iteration = self._state.iteration

    def __repr__(self) -> str:
        return f"<OutputPort {self.qualified_name} -> {self.topic or '?'} [{self.type.__name__}]>"


class InputPort(Port[T]):
    """An input port: ``read()`` returns the latest value on its topic, or None."""

    __slots__ = ("_seen", "producer")
    direction = "input"

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        super().__init__(component, name, type_)
        self._seen = 0
        self.producer: OutputPort[Any] | None = None

    def read(self) -> T | None:
        """Return the latest value (None before the first write) and mark it as seen."""
        slot = self._slot
        self._seen = slot.seq
        return slot.value

    @property
    def status(self) -> FlowStatus:
        """NEW_DATA if written since this port's last read, OLD_DATA if not, or NO_DATA."""
        seq = self._slot.seq
        if seq == 0:
            return FlowStatus.NO_DATA
        return FlowStatus.NEW_DATA if seq != self._seen else FlowStatus.OLD_DATA

    @property
    def iteration(self) -> int:
        """The loop iteration in which the value on this topic was written: with
        components at several rates, which iteration's value a reader sees (-1 before
        the first write, and for values fed from the middleware)."""
        return self._slot.iteration

    @property
    def has_new_data(self) -> bool:
        """True if the value was written since this port's last ``read()``."""
        return self._slot.seq != self._seen

    @property
    def connected(self) -> bool:
        """True if a producer inside the runner writes this input's topic."""
        return self.producer is not None

    def _connect(self, producer: OutputPort[Any] | None) -> None:
        """Share ``producer``'s slot, or get a fresh private one (no producer)."""
        slot = producer._slot if producer is not None else Slot()
        if producer is None and self.producer is None:
            slot = self._slot  # stays unconnected: keep what a bridge may have fed it
        if slot is not self._slot:
            self._slot = slot
            self._seen = 0
        self.producer = producer

    def __repr__(self) -> str:
        return f"<InputPort {self.qualified_name} <- {self.topic or '?'} [{self.type.__name__}]>"
