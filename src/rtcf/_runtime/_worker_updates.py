"""The worker's side of the update records: applied between two iterations, answered.

A tunable's value and a log level are applied as they come. A lifecycle transition is
applied and answered on the outcome ring with its request's number; the runner's own
changes (a fault policy's) go back with number 0. A STRICT switch comes as a ``BATCH``
record followed by its transitions, all in one ring commit: they are collected, then
applied all or nothing by the runner (:mod:`rtcf._core._switching`) before the
iteration's first update. Every change the batch made (undo included) goes back as
news (number 0: the supervisor's states and listeners hear of it), then each
transition's answer (its number negated: an answer only, no change to hear of twice).

Nothing here runs in the common iteration, which reads no record.
"""

from __future__ import annotations

from typing import Any

from .._core._lifecycle import REFUSED, TransitionOutcome, encode_outcome
from .._core._rings import Ring
from .._core._runner import Runner
from .._core._tunables import BATCH, LIFECYCLE


class UpdateApplier:
    """``apply(kind, component, name, value)`` for the worker's ``UpdateReader``."""

    def __init__(self, runner: Runner, outcomes: Ring | None) -> None:
        self._runner = runner
        self._outcomes = outcomes  # lifecycle outcomes, back to the supervisor
        self._applying = 0  # the number of the transition request being applied
        self._strict_left = 0  # transitions of a STRICT batch still to come
        self._batch: list[tuple[str, str, int]] = []  # (component, transition, number)
        runner.transition_listeners.append(self.report)

    def apply(self, kind: int, component: str, name: str, value: Any) -> None:
        """An update record (between iterations); a lifecycle transition is answered."""
        if kind == BATCH:  # a STRICT switch: its transitions follow
            self._batch.clear()
            self._strict_left = int(value)
            return
        if kind != LIFECYCLE:
            self._runner.apply_update(kind, component, name, value)
            return
        if self._strict_left:
            self._batch.append((component, name, int(value)))
            self._strict_left -= 1
            if not self._strict_left:
                self._switch()
            return
        self._applying = int(value)
        try:
            outcome = self._runner.apply_update(kind, component, name, value)
        finally:
            self._applying = 0
        if outcome is not None and outcome.result == REFUSED:  # no listener heard of it
            self.report(component, outcome, int(value))

    def _switch(self) -> None:
        """The STRICT batch, all or nothing; then the answers."""
        batch = self._batch
        outcomes = self._runner.switch([(c, t) for c, t, _ in batch], strict=True)
        for (component, _, number), outcome in zip(batch, outcomes, strict=True):
            self.report(component, outcome, -number)
        batch.clear()

    def report(self, component: str, outcome: TransitionOutcome,
               number: int | None = None) -> None:
        """Tell the supervisor of a lifecycle change: the answer to its request, or one
        the runner made itself (a fault policy's). A full ring drops it (counted)."""
        if self._outcomes is not None:
            request = self._applying if number is None else number
            self._outcomes.push(encode_outcome(request, outcome, component))
