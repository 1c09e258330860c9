"""Chained controllers, as ros2_control's ``ChainableControllerInterface``.

A :class:`ChainableComponent` exports **reference interfaces**: float64 values named
``<controller>/<key>`` (``pid_left/left_wheel_joint/velocity``) that a preceding
controller commands as it would a hardware's command interfaces, by key, from its
``add_command_interfaces`` port. With hardware in the run (the resource manager holds
the keys, rtcf._core._controller_references):

* the references exist from the controller's configure and are available while it is
  active; a preceding controller claims them at its activation like the hardware's
  keys (the same refusals), and only while the chained controller is active;
* while an active controller claims its references, the chained controller is **in
  chained mode** (:attr:`ChainableComponent.in_chained_mode`): it takes its references
  from the array, not from its topics; it leaves chained mode when no active controller
  claims them any more. As ros2_control does, a controller whose mode changes while it
  is active is restarted (``stop``, the mode, ``start``) between two iterations;
* each claimed reference key is an edge of the data-flow graph
  (:func:`reference_ports`), so Kahn's order runs the preceding controller first, and
  the value it wrote is read by the chained one in the same iteration.
"""

from __future__ import annotations

import heapq
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from ._component import Component
from ._errors import ComponentError
from ._graph import PortInfo
from ._interface_ports import COMMAND

REFERENCE_TOPIC = "@reference/"  # a reference key's edge in the graph: this + the key
REFERENCE_INPUT = "@references"  # the chained controller's end of those edges


class ReferenceInterfaces(NamedTuple):
    """A chainable controller's references: its keys, their full names, the values."""

    keys: tuple[str, ...]  # as declared: "<dof>/<interface>"
    full_keys: tuple[str, ...]  # "<controller>/<dof>/<interface>"
    values: np.ndarray


class ChainableComponent(Component):
    """A controller that other controllers can precede (ros2_control's
    ChainableControllerInterface): it exports reference interfaces
    (:meth:`add_reference_interfaces`) and reads them instead of its topics while it is
    :attr:`in_chained_mode` (docs/controllers.md#chained-controllers)."""

    _rtcf_references: ReferenceInterfaces | None = None
    _rtcf_chained: bool = False

    def add_reference_interfaces(self, keys: Sequence[str]) -> np.ndarray:
        """Export reference interfaces ``<name>/<key>`` (in ``configure``): the float64
        array returned holds their values (NaN until written), a value per key."""
        return declare_references(self, keys)

    @property
    def in_chained_mode(self) -> bool:
        """Whether a preceding controller writes the references (then ignore the topics)."""
        return self._rtcf_chained

    def on_set_chained_mode(self, chained_mode: bool) -> bool | None:
        """Called (while not active) before the mode changes; False refuses the change."""
        return None


def declare_references(component: Any, keys: Sequence[str]) -> np.ndarray:
    given = tuple(str(k) for k in ([keys] if isinstance(keys, str) else keys))
    problem = ""
    if not given:
        problem = "give at least one key"
    elif any("/" not in k.strip("/") for k in given):
        problem = "a key is '<dof>/<interface>', such as 'joint1/velocity'"
    elif len(set(given)) != len(given):
        problem = "a key is given twice"
    old = component._rtcf_references
    if not problem and component._rtcf_redeclared is not None:
        if old is not None and old.keys == given:
            return old.values  # configured again: the same references
        problem = "configured again, a controller must export the references of its first configure"
    elif not problem and (component._rtcf_configured or old is not None):
        problem = "declare reference interfaces once, in configure()"
    if problem:
        raise ComponentError(
            f"component {component.full_name!r}: reference interfaces {list(given)}: {problem}",
            component=component.full_name)
    values = np.full(len(given), np.nan)
    component._rtcf_references = ReferenceInterfaces(
        given, tuple(f"{component.name}/{k}" for k in given), values)
    return values


def references_of(component: Any) -> ReferenceInterfaces | None:
    return getattr(component, "_rtcf_references", None)


def chain_links(components: Mapping[str, Any]) -> list[tuple[str, str, str, str]]:
    """(preceding, its port, chained, full key) for each reference key a component's bound
    command port names, among ``components`` (full name -> component)."""
    exported = {key: name for name, comp in components.items()
                if (refs := references_of(comp)) is not None for key in refs.full_keys}
    links = []
    for name, comp in components.items():
        for port, ports in comp._rtcf_interfaces.items():
            if ports.kind != COMMAND or port not in comp._rtcf_bound:
                continue
            for key in ports.keys:
                owner = exported.get(key)
                if owner is not None and owner != name:
                    links.append((name, port, owner, key))
    return links


def reference_ports(components: Mapping[str, Any]
                    ) -> tuple[dict[str, list[PortInfo]], dict[str, list[PortInfo]]]:
    """The graph's ends of the reference keys (inputs, outputs by component): a claimed
    output of the preceding controller and an input of the chained one per key, on the
    topic ``@reference/<key>``."""
    inputs: dict[str, list[PortInfo]] = {}
    outputs: dict[str, list[PortInfo]] = {}
    for preceding, port, chained, key in chain_links(components):
        topic = REFERENCE_TOPIC + key
        outputs.setdefault(preceding, []).append(
            PortInfo(preceding, port, topic, np.ndarray, claimed=True))
        inputs.setdefault(chained, []).append(PortInfo(chained, REFERENCE_INPUT, topic, np.ndarray))
    return inputs, outputs


def chained_first(names: Sequence[str], components: Mapping[str, Any]) -> list[str]:
    """``names`` with each chained controller before the controllers that precede it
    (what activating them together needs: references available first), else as given."""
    place = {n: i for i, n in enumerate(names)}
    after: dict[str, set[str]] = {n: set() for n in names}  # chained -> its preceding
    waiting = dict.fromkeys(names, 0)
    for preceding, _, chained, _ in chain_links(components):
        if preceding in place and chained in place and preceding not in after[chained]:
            after[chained].add(preceding)
            waiting[preceding] += 1
    ready = [(place[n], n) for n in names if not waiting[n]]
    heapq.heapify(ready)
    order = []
    while ready:
        _, n = heapq.heappop(ready)
        order.append(n)
        for p in after[n]:
            waiting[p] -= 1
            if not waiting[p]:
                heapq.heappush(ready, (place[p], p))
    return order + [n for n in names if n not in order]  # (a cycle: as given)
