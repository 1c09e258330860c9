"""Ports that are hardware interfaces: ``Component.add_state_interfaces`` and
``add_command_interfaces``.

A controller declares which of ros2_control's interfaces a port carries, by their keys
(``joint1/position``), one float64 array per port with a value per key in the keys'
order. What the port then is depends on the run:

* **With hardware** (the runner has a robot description, rtcf._core._hardware_loop): the
  port is bound to the resource manager's buffers. It is no topic: it is kept out of
  the graph, the middleware and the per-topic claims (``_rtcf_bound``, not
  ``_rtcf_inputs``/``_rtcf_outputs``); the schedule gathers the states into the input
  before the component's update and scatters the command it wrote after it.
* **Without hardware**: an ordinary port of its name, as ``add_input(name, np.ndarray)``
  / ``add_output(name, np.ndarray, claim=True)`` declare it: launch files wire it with
  remaps, as before.

Either way the keys are recorded (``_rtcf_interfaces``): what a controller claims on
activation and what ``list_controllers`` says it requires.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ._errors import ComponentError
from ._names import validate_name
from ._ports import InputPort, OutputPort

STATE = "state"
COMMAND = "command"


class InterfacePorts(NamedTuple):
    """One port's interfaces: ``kind`` (state or command), the keys, the port."""

    kind: str
    keys: tuple[str, ...]
    port: Any


class HardwareKeys(NamedTuple):
    """What a component sees of the run's hardware (``Component.hardware``): every
    state and command interface its resource manager exports, by key."""

    state_keys: tuple[str, ...]
    command_keys: tuple[str, ...]


def declare_interfaces(component: Any, name: str, kind: str, keys: Sequence[str],
                       deadline: float | None = None) -> Any:
    """The port of ``component.add_state_interfaces``/``add_command_interfaces``."""
    if isinstance(keys, str):
        keys = [keys]
    given = tuple(str(k) for k in keys)
    named = [k for k in given if k]
    bad = [k for k in named if "/" not in k.strip("/")]
    problem = ""
    if not given or (kind == COMMAND and len(named) != len(given)):
        problem = "give at least one key, none empty"
    elif bad:
        problem = f"{bad[0]!r} is not a key; give '<joint>/<interface>' such as 'joint1/position'"
    elif len(set(named)) != len(named):
        problem = "a key is given twice"
    if problem:
        raise ComponentError(
            f"component {component.full_name!r}: {kind} interfaces {name!r} {list(given)}: "
            f"{problem}", component=component.full_name)
    port: Any
    if component._rtcf_hardware is None:  # a topic port, as before
        if kind == STATE:
            port = component.add_input(name, np.ndarray, deadline=deadline)
        else:
            port = component.add_output(name, np.ndarray, claim=True)
    else:
        if kind == STATE:
            port = InputPort(component.full_name, name, np.ndarray)
        else:
            port = OutputPort(component.full_name, name, np.ndarray, component._rtcf_state)
        port = add_port(component, port, component._rtcf_bound)
    component._rtcf_interfaces[name] = InterfacePorts(kind, given, port)
    return port


def required_interfaces(component: Any) -> tuple[list[str], list[str]]:
    """(command keys, state keys) a component's interface ports name, each sorted."""
    commands: set[str] = set()
    states: set[str] = set()
    for ports in component._rtcf_interfaces.values():
        (commands if ports.kind == COMMAND else states).update(k for k in ports.keys if k)
    return sorted(commands), sorted(states)


def add_port(self: Any, port: Any, table: dict[str, Any]) -> Any:
    """A port declared by ``self`` (a component) in ``table``: named, checked, resolved;
    configured again, the port of the first configure (``_redeclare``)."""
    if self._rtcf_redeclared is not None:
        return _redeclare(self, port, table)
    what = f"component {self.full_name!r}: port name"
    if self._rtcf_configured:
        raise ComponentError(
            f"component {self.full_name!r}: add_input/add_output called after configure(); "
            "declare ports in configure()",
            component=self.full_name,
        )
    if not isinstance(port.type, type):
        raise ComponentError(
            f"component {self.full_name!r}: port {port.name!r} has type {port.type!r}, "
            "which is not a class; pass a class such as float or a message type",
            component=self.full_name,
        )
    problem = validate_name(port.name, what=what)
    if problem:
        raise ComponentError(problem, component=self.full_name)
    if (port.name in self._rtcf_inputs or port.name in self._rtcf_outputs
            or port.name in self._rtcf_bound):
        raise ComponentError(
            f"component {self.full_name!r}: port {port.name!r} is declared twice; "
            "give each port a unique name",
            component=self.full_name,
        )
    port.topic = self._rtcf_resolver.resolve(port.name)
    table[port.name] = port
    return port

def _redeclare(self: Any, port: Any, table: dict[str, Any]) -> Any:
    """configure() again: the port of the first configure, if it is the same one."""
    old = table.get(port.name)
    redeclared = self._rtcf_redeclared
    assert redeclared is not None
    if old is None or old.type is not port.type or port.name in redeclared:
        kind = "input" if isinstance(port, InputPort) else "output"
        raise ComponentError(
            f"component {self.full_name!r}: configure() declared the {kind} port "
            f"{port.name!r} ({getattr(port.type, '__name__', port.type)}), which its first "
            "configure() did not declare like this; configured again, a component must "
            "declare the same ports (its connections were made for them): unload and load "
            "it to change its ports",
            component=self.full_name,
        )
    redeclared.add(port.name)
    return old
