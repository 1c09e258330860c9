"""A switch: lifecycle transitions applied together between two iterations.

A controller manager's ``switch_controller`` is a batch of transitions (the
deactivations, then the activations) that the loop applies at the start of one
iteration, so that iteration already runs with the switch made. ``BEST_EFFORT``
applies each and leaves the failed ones out. ``STRICT`` is all or nothing within that
same iteration: when one transition fails (a ``start`` that returns False or raises,
a claim refused), the ones after it are not made and the ones made before it are
undone, in reverse order (an activation deactivated, a deactivation activated again),
before any component's next ``update``. So no iteration runs with the switch half
made: on a robot, no command is written by a controller whose switch was refused.

Each transition's answer says what became of it: its own outcome (the one that
failed), or ``UNDONE`` with the state it is in now (made and undone, or not made). The
undo's own transitions are lifecycle changes like any (logged, told to the
listeners). One log line names the switch's failure and what was undone.
"""

from __future__ import annotations

from collections.abc import Sequence

from ._hardware_loop import HARDWARE_PREFIX, HardwareLoop
from ._lifecycle import (
    ACTIVATE,
    DEACTIVATE,
    UNDONE,
    UNKNOWN,
    TransitionOutcome,
)
from ._log import LogLevel
from ._notices import Notices
from ._transitions import Transitions

# what undoes a switch's transition (a switch is activations and deactivations)
_UNDO = {ACTIVATE: "deactivate", DEACTIVATE: "activate"}


class Switching:
    """Applies lifecycle transitions asked for between iterations: one at a time
    (:meth:`change`), or a switch's batch (:meth:`switch`), STRICT all or nothing."""

    def __init__(self, name: str, transitions: Transitions, hardware: HardwareLoop | None,
                 notices: Notices) -> None:
        self._name = name  # the runner's, for its log line
        self._transitions = transitions
        self._hardware = hardware
        self._notices = notices

    def change(self, component: str, transition: int | str) -> TransitionOutcome:
        """One transition: a component's, or (``@hardware/<name>``) a hardware's state."""
        if component.startswith(HARDWARE_PREFIX) and self._hardware is not None:
            return self._hardware.transition(component, str(transition))
        return self._transitions.change(component, transition)

    def switch(self, steps: Sequence[tuple[str, int | str]], strict: bool
               ) -> list[TransitionOutcome]:
        """Apply ``steps`` (component, transition) in order, now; the answers in that
        order. ``strict``: a failure undoes the transitions made before it, at once."""
        outcomes: list[TransitionOutcome] = []
        for component, transition in steps:
            outcome = self.change(component, transition)
            outcomes.append(outcome)
            if strict and not outcome.ok:
                break
        else:
            return outcomes
        failed = len(outcomes) - 1
        why = (f"the STRICT switch failed at {transition!r} of {component!r} "
               f"({outcomes[failed].describe()})")
        outcomes += [TransitionOutcome(0, UNKNOWN, UNKNOWN, UNDONE, reason=f"not made: {why}")
                     for _ in steps[failed + 1:]]
        undone: list[str] = []
        for k in reversed(range(failed)):  # the ones made, last first
            made, (name, _) = outcomes[k], steps[k]
            inverse = _UNDO.get(made.transition)
            back = self.change(name, inverse) if inverse else None
            if back is not None and back.ok:
                undone.append(f"{name} {inverse}d again")
                reason = f"undone: {why}"
                end = back.end
            else:
                undone.append(f"{name} NOT {inverse or 'undone'}")
                said = back.describe() if back is not None else f"no undo for {made.label}"
                end = made.end if back is None else back.end
                reason = f"could not be undone ({said}): {why}"
            outcomes[k] = TransitionOutcome(made.transition, made.start, end, UNDONE, "", reason)
        self._notices.log(
            LogLevel.ERROR, self._name,
            f"switch: {why}; undone in the same iteration: {', '.join(undone) or 'nothing'}"
            + ("" if all(o.start == o.end for o in outcomes[:failed]) else
               "; a transition could not be undone: check those components' states"))
        return outcomes
