"""pid_controller's ``~/reference`` and ``~/measured_state`` messages and its states:
checked, then taken into the controller's references or measured state (kept apart from
the controller, which runs the loop on them)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_isnan = math.isnan


def take_reference(c: Any, msg: Any) -> None:
    """A ``~/reference`` message into ``c``'s references (``c``: a PidController), or
    refused: the wrong sizes, an unknown dof, an infinite value (a NaN one leaves its
    dof's reference, as in ros2_controllers)."""
    names, values, dots = msg.dof_names, msg.values, msg.values_dot
    n = len(c.dofs)
    if len(values) != n or (names and len(names) != n) or (dots and len(dots) != n):
        c.refused_messages["~/reference"] += 1
        c.refused.error(
            "%s refused: %d names, %d values and %d values_dot for %d dofs (%s)",
            c.reference_port.topic, len(names), len(values), len(dots), n,
            ", ".join(c.state_dofs))
        return
    if names:
        order = [c.index.get(name, -1) for name in names]
        if -1 in order:
            c.refused_messages["~/reference"] += 1
            c.unknown.error(
                "%s refused: dof %r is not one of %s", c.reference_port.topic,
                names[order.index(-1)], ", ".join(c.state_dofs))
            return
    else:
        order = list(range(n))
        c.unnamed.warning(
            "%s has no dof_names: its values are taken in the order of %s",
            c.reference_port.topic, ", ".join(c.state_dofs))
    for field, numbers in (("value", values), ("value_dot", dots)):
        # infinite: refused; NaN: "leave this dof's reference" (ros2_controllers)
        infinite = [k for k, x in enumerate(numbers) if math.isinf(x)]
        if infinite:
            k = infinite[0]
            c.refused_messages["~/reference"] += 1
            c.not_finite["~/reference"].error(
                "%s refused: the %s of %s is %r (not finite); the last reference stays",
                c.reference_port.topic, field, c.state_dofs[order[k]],
                float(numbers[k]))
            return
    two = c.two and len(dots) == n
    for k, i in enumerate(order):
        value = values[k]
        if not _isnan(value):
            c.reference[i] = value
            if two and not _isnan(dots[k]):
                c.reference_dot[i] = dots[k]


def refuse_state(c: Any, name: str, topic: str, values: Any, finite: Any) -> None:
    """A state with a value that is not finite: ignored, the last ones stay."""
    c.refused_messages[name] += 1
    i = int(np.argmin(finite))
    c.not_finite[name].error(
        "%s ignored: the value of %s is %r (not finite); the last ones stay",
        topic, c.state_dofs[i], float(values[i]))


def take_measured(c: Any, msg: Any) -> None:
    """A ``~/measured_state`` message into ``c``'s measured state, or refused."""
    names, values, dots = msg.dof_names, msg.values, msg.values_dot
    n = len(c.dofs)
    problem = None
    if len(names) != n or len(values) != n:
        problem = f"{len(names)} names and {len(values)} values"
    elif dots and not c.two:
        problem = "values_dot, which needs two reference_and_state_interfaces"
    elif dots and len(dots) != n:
        problem = f"{len(dots)} values_dot"
    if problem is not None:
        c.refused_messages["~/measured_state"] += 1
        c.refused.error("%s refused: %s for %d dofs (%s)", c.measured_port.topic, problem, n,
                        ", ".join(c.state_dofs))
        return
    for numbers in (values, dots):
        finite = np.isfinite(np.asarray(numbers, dtype=float))  # a message: rare
        if not finite.all():
            refuse_state(c, "~/measured_state", c.measured_port.topic, numbers, finite)
            return
    c.measured = list(values)
    c.measured_dot = list(dots) if dots else [math.nan] * n
