"""Chained controllers as the controller manager's services show and switch them.

From the components' introspection (rtcf._core._chaining gives each its ``chainable``
flag and ``references``), by controller name (relative to the controller manager's
namespace), what ros2_control Jazzy's ``list_controllers`` fills: ``is_chainable``,
``is_chained`` (an active controller claims one of its references),
``reference_interfaces`` (without the controller's prefix) and ``chain_connections``
(for each controller whose command interfaces name another controller as their prefix:
that controller, with every such interface, as Jazzy lists them); and the order a
switch applies its transitions in: deactivations of preceding controllers before those
they precede, activations of chained controllers before those that precede them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

Info = Mapping[str, Any]


def _prefix(key: str) -> tuple[str, str]:
    prefix, _, rest = key.partition("/")
    return prefix, rest


def links(infos: Mapping[str, Info]) -> list[tuple[str, str]]:
    """(preceding, chained) for each command interface that names a chainable
    controller's reference interface (controllers by name)."""
    found = []
    for name, info in infos.items():
        for key in (info.get("interfaces") or ((), ()))[0]:
            owner, rest = _prefix(str(key))
            target = infos.get(owner)
            if target is not None and owner != name and target.get("chainable") and (
                    rest in target.get("references", ())):
                found.append((name, owner))
    return found


def fill(state: Any, name: str, infos: Mapping[str, Info], connection: Any) -> None:
    """Set a ControllerState's chain fields as Jazzy's list_controllers does."""
    info = infos[name]
    state.is_chainable = bool(info.get("chainable"))
    state.is_chained = state.is_chainable and any(
        chained == name and infos[preceding].get("lifecycle") == "active"
        for preceding, chained in links(infos))
    if info.get("lifecycle") not in ("active", "inactive"):
        return
    state.reference_interfaces = [str(k) for k in info.get("references", ())]
    named: set[str] = set()
    interfaces: list[str] = []
    for key in (info.get("interfaces") or ((), ()))[0]:
        prefix, rest = _prefix(str(key))
        if prefix in infos:
            named.add(prefix)
            interfaces.append(rest)
    state.chain_connections = [connection(name=n, reference_interfaces=interfaces)
                               for n in sorted(named)]


def switch_order(deactivate: Sequence[str], activate: Sequence[str],
                 infos: Mapping[str, Info]) -> tuple[list[str], list[str]]:
    """The deactivations with preceding controllers first, the activations with chained
    controllers first; otherwise in the order asked."""
    pairs = links(infos)
    return _ordered(deactivate, pairs), _ordered(activate, [(c, p) for p, c in pairs])


def _ordered(names: Sequence[str], first: list[tuple[str, str]]) -> list[str]:
    """``names`` with each ``a`` before ``b`` for (a, b) in ``first``, stable."""
    left = list(names)
    order: list[str] = []
    while left:
        ready = next((n for n in left if not any(
            b == n and a in left and a != n for a, b in first)), left[0])  # (a cycle: as asked)
        order.append(ready)
        left.remove(ready)
    return order
