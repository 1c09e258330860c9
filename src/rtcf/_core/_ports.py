"""Ports: typed inputs and outputs of a component, connected through shared slots.

An output owns a :class:`Slot`; every input connected to it holds a reference to
that same slot, so a write is three stores and a read is one look-up: no copy, no
queue, no allocation. Slots and the ports' read, write and status are the hot path
(:mod:`rtcf._core._hotpath`): compiled where rtcf could build it. Values pass by
reference: do not mutate an object after writing it (write a new one, or a copy).

An input with no producer gets a slot of its own that nothing inside the runner
writes (a middleware bridge may feed it between iterations).
"""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from ._hotpath import PortCore, Slot, set_flow_status

T = TypeVar("T")
__all__ = ["FlowStatus", "InputPort", "OutputPort", "Port", "Slot"]


class FlowStatus(enum.IntEnum):
    """What an input holds, as OROCOS tells it: nothing yet, an old value, a new one."""

    NO_DATA = 0
    OLD_DATA = 1
    NEW_DATA = 2


set_flow_status(FlowStatus.NO_DATA, FlowStatus.OLD_DATA, FlowStatus.NEW_DATA)


class Port(PortCore, Generic[T]):
    """Common part of inputs and outputs."""

    __slots__ = ("component", "name", "topic", "type")

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        self.component = component  # full name of the owning component
        self.name = name  # name given in add_input/add_output
        self.type = type_
        self.topic = ""  # resolved topic name, set when the runner wires the graph
        # (its slot, its loop state, what it last read: PortCore's, in the hot path)

    @property
    def qualified_name(self) -> str:
        return f"{self.component}.{self.name}"


class OutputPort(Port[T]):
    """An output port: ``write(value)`` makes ``value`` the topic's latest value."""

    __slots__ = ()
    direction = "output"

    def __init__(self, component: str, name: str, type_: type[T], state: Any = None) -> None:
        super().__init__(component, name, type_)
        # the loop's state: a write records its iteration (-1 for a port outside a loop)
        self._state = state
        # (its tap, set while the port is mapped to the middleware or recorded, is
        # PortCore's: a tapped port's class is one whose write calls it)

    if TYPE_CHECKING:

        def write(self, value: T) -> None:
            """Make ``value`` the topic's latest value."""

    else:  # the hot path's (compiled where it could be built): the slot takes the
        # value, counts the write and records the loop's iteration
        write = PortCore._write

    def __repr__(self) -> str:
        return f"<OutputPort {self.qualified_name} -> {self.topic or '?'} [{self.type.__name__}]>"


class InputPort(Port[T]):
    """An input port: ``read()`` returns the latest value on its topic, or None."""

    __slots__ = ("producer",)
    direction = "input"

    def __init__(self, component: str, name: str, type_: type[T]) -> None:
        super().__init__(component, name, type_)
        self.producer: OutputPort[Any] | None = None

    if TYPE_CHECKING:

        def read(self) -> T | None:
            """Return the latest value (None before the first write) and mark it as seen."""

        @property
        def status(self) -> FlowStatus:
            """NEW_DATA if written since this port's last read, OLD_DATA if not, or NO_DATA."""

        @property
        def iteration(self) -> int:
            """The loop iteration in which the value on this topic was written: with
            components at several rates, which iteration's value a reader sees (-1 before
            the first write, and for values fed from the middleware)."""

        @property
        def has_new_data(self) -> bool:
            """True if the value was written since this port's last ``read()``."""

    else:  # the hot path's (compiled where it could be built)
        read = PortCore._read
        status = PortCore._status
        iteration = PortCore._iteration
        has_new_data = PortCore._has_new_data

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
