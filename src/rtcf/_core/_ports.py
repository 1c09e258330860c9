"""Ports: typed inputs and outputs of a component, connected through shared slots.

An output owns a :class:`Slot`; every input connected to it holds a reference to
that same slot, so a write is three stores and a read is one look-up: no copy, no
queue, no allocation. Slots and the ports' read, write and status are the hot path
(:mod:`rtcf._core._hotpath`): C types where rtcf could build them, else the same in
Python. An output's tap (``_tap``) is called with every value written while the port
is mapped to the middleware or recorded. Values pass by
reference: do not mutate an object after writing it (write a new one, or a copy).

An input with no producer gets a slot of its own that nothing inside the runner
writes (a middleware bridge may feed it between iterations).
"""

from __future__ import annotations

import enum

from ._hotpath import InputPort, OutputPort, Port, Slot, set_flow_status

__all__ = ["FlowStatus", "InputPort", "OutputPort", "Port", "Slot"]


class FlowStatus(enum.IntEnum):
    """What an input holds, as OROCOS tells it: nothing yet, an old value, a new one;
    and, for an input with a deadline, a value older than it (``EXPIRED``: the
    publisher went silent; the loop's deadline policy applies, docs/runner.md)."""

    NO_DATA = 0
    OLD_DATA = 1
    NEW_DATA = 2
    EXPIRED = 3


set_flow_status(
    FlowStatus.NO_DATA, FlowStatus.OLD_DATA, FlowStatus.NEW_DATA, FlowStatus.EXPIRED
)
