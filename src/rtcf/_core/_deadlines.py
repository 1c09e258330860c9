"""Input deadlines: the loop's watch over inputs whose publisher may go silent.

An input with a deadline (``add_input(..., deadline=0.1)``, or the launcher parameter
``deadline/NAME``) is watched at every iteration boundary, after the feeders (which
copy what the middleware delivered) and before the first update, on the loop's own
clock (``state.time_ns``: the same under ``--sim``, /clock time and real time). A
value *arrives* at the start of the first iteration in which it is in its slot: a
value a component writes in the loop, at the start of the iteration that wrote it;
one another lane hands over (a LET lane's output at its window's end), of the
iteration it is handed over in; one fed from the middleware, of the iteration whose
feeders fed it. The deadline applies in the first iteration whose start is later than the
last arrival plus the deadline: the port's status turns ``EXPIRED`` and the
component's ``on_deadline`` policy applies (``continue``: the component decides;
``deactivate``: out of the schedule, its fallback takes over; ``stop``: the loop ends
through the safe stops). The next value clears it: the status is ``NEW_DATA`` as soon
as it is written, also by a component earlier in the same iteration (the port keeps
the seq it expired at: ``EXPIRED`` only while that value is the latest), and the
watch records the return in the iteration that wrote it. A component the policy took
out comes back as ``activate`` brings it back (and its fallback stands by again), at
the next iteration boundary. Nothing is watched before an input's first value (its
status says ``NO_DATA``).

Each time a deadline applies is a :class:`DeadlineEvent` (the iteration it applied
in, and the iteration and time the input came back), and each input's count and
total time past its deadline are what timing.json, the run's summary and
/diagnostics report.

The per-iteration look is a :class:`DeadlineGate` (compiled, or its Python twin): it
keeps each input's last seq and due time in two lists of words (int64 words for the
compiled one) and calls :meth:`check` only in an iteration where something changes
(an input past its deadline has a value again, or one passes its due time), so the
compiled loop's steady state costs no Python call.
"""


from __future__ import annotations

import sys
from array import array
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

from ._errors import ComponentError
from ._faults import DEADLINE_CONTINUE, DEADLINE_DEACTIVATE, DEADLINE_STOP
from ._hotpath import DeadlineGate, gate_words
from ._interpreted import NO_LOOK
from ._lifecycle import ACTIVE
from ._log import LogLevel

if TYPE_CHECKING:
    from ._components import Components, Loaded
    from ._containment import Containment
    from ._loop_state import LoopState
    from ._notices import Notices
    from ._ports import InputPort

MAX_EVENTS = 1000  # kept per runner's life (the counts go on past it)
NEVER = sys.maxsize


@dataclass
class DeadlineEvent:
    """One time an input's deadline applied, and when its next value came."""

    port: str  # component.input
    topic: str
    deadline: float  # seconds
    iteration: int  # the first iteration past it (where the policy applied)
    time: float  # that iteration's start, seconds on the loop's clock
    last_arrival: float  # when the last value arrived (see the module's docstring)
    action: str  # continue, deactivated, stopped
    back_iteration: int = -1  # the iteration the next value arrived in (-1: never)
    back_time: float = -1.0
    fallback: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def describe(self) -> str:
        return (
            f"input {self.port!r} ({self.topic}) past its deadline of {self.deadline:g} s at "
            f"iteration {self.iteration} (t={self.time:.6f} s; last value at "
            f"t={self.last_arrival:.6f} s): on_deadline "
            + {"continue": "continue", "deactivated": "deactivate", "stopped": "stop"}.get(
                self.action, self.action
            )
            + (f"; {self.fallback} took over" if self.fallback else "")
        )


@dataclass(slots=True)
class _Track:
    """What the watch keeps of one input across runs."""

    port: InputPort[Any]
    entry: Loaded
    deadline_ns: int
    # between runs (in a run, DeadlineWatch.seq and .due hold them): the slot's seq
    # last seen, and last arrival + deadline: past it, the deadline applies (NEVER:
    # nothing yet, or past it already)
    seq: int = 0
    due_ns: int = sys.maxsize
    since_ns: int = 0  # when it expired
    count: int = 0
    total_ns: int = 0  # past its deadline, the periods that ended
    event: DeadlineEvent | None = None  # the open one
    bit: int = 0  # its bit in DeadlineWatch.bits (0: past the 63rd)


@dataclass
class DeadlineWatch:
    """Watches the inputs with a deadline; called as the loop's last feeder."""

    state: LoopState
    components: Components
    containment: Containment
    notices: Notices
    tracks: dict[int, _Track] = field(default_factory=dict)  # by id(port)
    events: list[DeadlineEvent] = field(default_factory=list)
    taken_out: dict[str, str] = field(default_factory=dict)  # component -> its fallback
    # a worker's shared words: bit k set while the k-th watched input (names()) is past
    # its deadline, and how many times any passed it (a supervisor reads them live)
    bits: Any = field(default_factory=lambda: array("q", [0]))
    misses: Any = field(default_factory=lambda: array("q", [0]))
    _watched: tuple[_Track, ...] = ()
    # per watched input (in _watched's order): its slot's seq last seen, its due time
    seq: Any = field(default_factory=lambda: gate_words([]))
    due: Any = field(default_factory=lambda: gate_words([]))
    gate: Any = None  # the loop's feeder (a DeadlineGate): calls check when due

    def refresh(self) -> bool:
        """Watch the inputs with a deadline of the components now loaded (before a run;
        a launch file's ``deadline/NAME`` was applied at load). True if any."""
        for k, track in enumerate(self._watched):  # what the last run saw
            track.seq, track.due_ns = self.seq[k], self.due[k]
        tracks: dict[int, _Track] = {}
        for entry in self.components.entries.values():
            for port in entry.component.inputs.values():
                if port._deadline_ns <= 0:
                    continue
                old = self.tracks.get(id(port))
                track = old if old is not None and old.port is port else _Track(
                    port, entry, port._deadline_ns
                )
                if track.due_ns != NEVER:  # a deadline the launch file changed
                    track.due_ns += port._deadline_ns - track.deadline_ns
                track.entry, track.deadline_ns = entry, port._deadline_ns
                tracks[id(port)] = track
        self.tracks = tracks
        self._watched = tuple(tracks.values())
        last = (NO_LOOK, 0) if self.gate is None else (
            self.gate.last_iteration, self.gate.last_time_ns
        )
        bits = 0
        for k, track in enumerate(self._watched):
            track.bit = 1 << k if k < 63 else 0
            bits |= track.bit if track.port._expired else 0
        self.bits[0] = bits
        if self.gate is not None:
            self.gate.release()
        self.seq = gate_words([t.seq for t in self._watched])
        self.due = gate_words([t.due_ns for t in self._watched])
        self.gate = DeadlineGate(
            self.state, tuple(t.port for t in self._watched), self.seq, self.due, self.check
        )
        self.gate.last_iteration, self.gate.last_time_ns = last  # across runs, too
        return bool(tracks)

    def names(self) -> list[str]:
        """The watched inputs (component.input), in the order of the bits."""
        self.refresh()
        return [t.port.qualified_name for t in self._watched]

    def check(self) -> None:
        """At an iteration boundary: arrivals, then deadlines passed (what the gate
        calls when something changes; the same look it takes, and what follows)."""
        i, t = self.state.iteration, self.state.time_ns
        last_i, last_t = self.gate.last_iteration, self.gate.last_time_ns
        seqs, dues = self.seq, self.due
        for k, track in enumerate(self._watched):
            slot = track.port._slot
            seq = slot.seq
            if seq != seqs[k]:
                seqs[k] = seq
                # came in the loop since the last look (a write, a lane's handover): then
                came = 0 <= slot.iteration <= last_i
                arrived, arrival = (last_i, last_t) if came else (i, t)
                dues[k] = arrival + track.deadline_ns
                if track.port._expired:
                    self._back(track, arrived, arrival)
            elif t > dues[k] and track.entry.state == ACTIVE:
                self._expire(track, k, t)

    def summary(self) -> dict[str, dict[str, Any]]:
        """Per input with a deadline: how many times it passed it, for how long in all
        (an ongoing one counted to the current iteration)."""
        now = self.state.time_ns
        out = {}
        for track in self.tracks.values():
            ongoing = now - track.since_ns if track.port._expired else 0
            out[track.port.qualified_name] = {
                "topic": track.port.topic,
                "deadline": track.deadline_ns / 1e9,
                "expired": track.count,
                "expired_seconds": (track.total_ns + ongoing) * 1e-9,
                "past_deadline_now": bool(track.port._expired),
            }
        return out

    def expired_now(self) -> list[str]:
        """The inputs past their deadline now, by name."""
        return [t.port.qualified_name for t in self._watched if t.port._expired]

    # -- what happens, rarely: outside the steady state ----------------------------
    def _expire(self, track: _Track, k: int, t: int) -> None:
        port, entry = track.port, track.entry
        port._expired = port._slot.seq  # EXPIRED while this value is the latest
        arrival = self.due[k] - track.deadline_ns
        self.due[k] = NEVER  # until the next value
        self.bits[0] |= track.bit
        self.misses[0] += 1
        track.since_ns = t
        track.count += 1
        name = entry.spec.full_name
        policy = entry.spec.policy
        action = {DEADLINE_DEACTIVATE: "deactivated", DEADLINE_STOP: "stopped"}.get(
            policy.on_deadline, "continue"
        )
        event = DeadlineEvent(
            port.qualified_name, port.topic, track.deadline_ns / 1e9, self.state.iteration,
            t / 1e9, arrival / 1e9, action,
        )
        track.event = event
        if len(self.events) < MAX_EVENTS:
            self.events.append(event)
        if policy.on_deadline == DEADLINE_CONTINUE:
            self.notices.log(LogLevel.WARNING, name, event.describe())
            return
        if policy.on_deadline == DEADLINE_STOP:
            self.notices.log(LogLevel.ERROR, name, event.describe())
            self.containment.safe_stop(f"input {port.qualified_name!r} past its deadline")
            raise ComponentError(
                f"component {name!r}: {event.describe()}; the loop was stopped", component=name
            )
        event.fallback = self.containment.take_out_for_deadline(
            name, self.state.iteration, event.describe()
        )
        self.taken_out[name] = event.fallback

    def _back(self, track: _Track, iteration: int, t: int) -> None:
        """The input has a value again, which arrived at iteration ``iteration`` (its
        start ``t``: this one, or the last one when a component wrote it there)."""
        port = track.port
        port._expired = 0
        self.bits[0] &= ~track.bit
        track.total_ns += t - track.since_ns
        event = track.event
        if event is not None:
            event.back_iteration = iteration
            event.back_time = t / 1e9
            track.event = None
        name = track.entry.spec.full_name
        self.notices.log(
            LogLevel.INFO, name,
            f"input {port.qualified_name!r} ({port.topic}) has a value again at iteration "
            f"{iteration}, after {(t - track.since_ns) * 1e-9:.6f} s past its deadline",
        )
        if name in self.taken_out and not any(
            w.port._expired for w in self._watched if w.entry is track.entry
        ):
            fallback = self.taken_out.pop(name)
            self.containment.bring_back(name, fallback)
