"""An event a reader holds is not rewritten under it (issue 39's debt): the server
writes each event into its own preallocated object, in rotation."""

from __future__ import annotations

from typing import Any

import rtcf
from rtcf import ActionEvent
from rtcf.testing import Goal, run_components

from .test_actions import NAME, Fibonacci, FibServer


class Holder(rtcf.Component):
    """Reads the server's events port, as a component in another lane would, and
    checks in the next iteration that the event it read then is still what it was."""

    def configure(self) -> None:
        self.events = self.add_input(f"{NAME}/_action/events", ActionEvent)
        self.held: tuple[Any, tuple[int, int, int, Any]] | None = None
        self.changed: list[str] = []
        self.seen = 0

    def update(self) -> None:
        if self.held is not None:
            event, fields = self.held
            now = (event.kind, event.goal_id, event.status, event.message)
            if now != fields:
                self.changed.append(f"{fields} -> {now}")
        event = self.events.read()
        if event is not None:
            self.seen += 1
            self.held = (event, (event.kind, event.goal_id, event.status, event.message))


def test_an_event_read_stays_as_it_was_while_the_server_writes_on() -> None:
    trace = run_components([FibServer, Holder], 12,
                           actions={NAME: {1: Goal(Fibonacci.Goal(order=6), id=3)}})
    holder = trace.components["/Holder"]
    assert isinstance(holder, Holder)
    assert holder.seen >= 3
    assert holder.changed == []
