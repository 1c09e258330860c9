"""Claimed commands: a topic several components may write, one active at a time.

ros2_control loads several controllers for the same joints (a trajectory controller
for MoveIt, a forward controller for teleop), each claiming the same command
interfaces; one is active, and a switch moves the claim. In rtcf a command interface
is a topic, and an output declared ``add_output(..., claim=True)`` claims it: the
graph lets several claimed outputs (of one lane) write a topic and orders them all
before its readers, the schedule gives them one slot (the readers see what the active
one wrote; while none is active, the last value stays), and the lifecycle refuses
to activate a component whose claimed topic another active component holds. That
check is here, where every activation passes (lifecycle services, a switch,
rtcf.testing, a fallback), not in the loop: the loop costs the same with claims.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import Any, Protocol

from ._lifecycle import ACTIVE


class Loaded(Protocol):
    """What is checked of a loaded component (``_components.Loaded``)."""

    state: int
    component: Any
    spec: Any


def claimed_topics(component: Any) -> list[str]:
    """The topics of ``component``'s claimed outputs, sorted."""
    outputs = component._rtcf_outputs
    return sorted(outputs[n].topic for n in component._rtcf_claims if n in outputs)


def activation_conflict(entries: Mapping[str, Loaded], name: str) -> str:
    """Why ``name`` may not be activated now ("" if it may): a topic it claims is held
    by another active component (ros2_control's words, with the holder)."""
    mine = set(claimed_topics(entries[name].component))
    if not mine:
        return ""
    for other, entry in entries.items():
        if other == name or entry.state != ACTIVE:
            continue
        held = mine.intersection(claimed_topics(entry.component))
        if held:
            return (
                f"Resource conflict for component '{name}'. Command topic '{min(held)}' is "
                f"already claimed by the active component '{other}': deactivate '{other}' "
                "first (or in the same switch_controller request)"
            )
    return ""


def start_conflict(
    entries: Mapping[str, Loaded], starting: Collection[str]
) -> tuple[str, str]:
    """Why the components ``starting`` may not all start ("" if they may), and the
    second of two claimants of one topic that would be active at once (its file and
    line go with the error)."""
    holders: dict[str, str] = {}
    for name, entry in entries.items():
        if entry.state != ACTIVE and name not in starting:
            continue
        for topic in claimed_topics(entry.component):
            if topic in holders:
                return (
                    f"components {holders[topic]!r} and {name!r} both claim the command topic "
                    f"{topic!r} and would both start active; at most one claimant of a topic is "
                    "active at a time: start one inactive (a spawner's --inactive, a "
                    "launcher's parameter autostart false, or autostart=False in its "
                    "ComponentSpec) and switch to it with "
                    "switch_controller or a lifecycle activate",
                    name,
                )
            holders[topic] = name
    return "", ""
