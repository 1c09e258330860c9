"""Lanes: which worker process runs which component, and what crosses between them.

A runner's components run in its **main lane** unless their launcher names another
(``lane``). Each lane is a worker process of its own. A lane whose components run at
the loop's rate runs in **lock step** with the main lane: every iteration, all lanes
start from the same deadline, and a value that crosses lanes is handed over through a
slot stamped with its iteration, so a reader waits for exactly the value the
sequential run would have given it. A lane whose components all run every N > 1
iterations runs on **logical execution time** (LET): released in iteration ``i`` it
reads its inputs as iteration ``i - 1`` left them, and its outputs become visible at
the start of iteration ``i + N``, however long it took.

This module holds what every lane computes alike, from the same facts about every
component wherever it is loaded: the lanes and their kinds, and for one lane its
**steps**: component updates in the global data-flow order, with the handovers put
where the sequential run would read and write the crossing values. The runtime
(:mod:`rtcf._runtime._lanes`) turns handovers into shared-memory slots; in one
process (``rtcf.testing``, ``rtcf graph``) :class:`LocalLet` gives the same values
with plain slots.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from ._cdr import Serialized
from ._errors import ConfigurationError
from ._lane_names import MAIN_LANE
from ._loop_state import LoopState
from ._ports import Slot

# step kinds of a lane
UPDATE = "update"  # a component's update
SEND = "send"  # after the producer: the value of this iteration, for other lanes
RECV = "recv"  # before a reader: the value of this iteration (or, delayed, the last one)
TAKE = "take"  # a LET lane at its release: the value as iteration i - 1 left it
LET_OUT = "let_out"  # a LET lane after its components: its outputs for i + N
LET_IN = "let_in"  # a reader of a LET lane's output: at the window's start, the new value


def lane_of(name: str) -> str:
    """The lane a launcher's ``lane`` names ("" is the main lane)."""
    return name or MAIN_LANE


@dataclass(frozen=True)
class Member:
    """What every lane must know of one component, wherever it is loaded."""

    name: str  # full name
    lane: str
    every: int = 1
    phase: int | None = None
    cost: float = 1.0
    scheduled: bool = True  # it overrides update (else the loop never calls it)


@dataclass(frozen=True)
class Lane:
    name: str
    members: tuple[str, ...]  # in the data-flow order
    every: int = 1  # > 1: logical execution time
    phase: int = 0  # LET: released in iterations i with (i - phase) % every == 0

    @property
    def let(self) -> bool:
        return self.every > 1


@dataclass(frozen=True)
class Step:
    kind: str  # UPDATE, SEND, RECV, TAKE, LET_OUT, LET_IN
    name: str  # the component (UPDATE) or the topic
    delayed: bool = False  # RECV: the value of the previous iteration
    source: str = ""  # the producing lane (RECV, TAKE, LET_IN)

    @property
    def label(self) -> str:
        """Its timing column: a component's name, or ``@kind topic`` for a handover."""
        return self.name if self.kind == UPDATE else f"@{self.kind} {self.name}"


def lanes_of(members: Sequence[Member], order: Sequence[str]) -> dict[str, Lane]:
    """The lanes (main first, then by name), each with its kind; a clear error for a
    lane other than main whose components do not share one rate."""
    rank = {n: k for k, n in enumerate(order)}
    by_lane: dict[str, list[Member]] = {MAIN_LANE: []}
    for m in members:
        by_lane.setdefault(m.lane, []).append(m)
    lanes: dict[str, Lane] = {}
    for name in [MAIN_LANE, *sorted(n for n in by_lane if n != MAIN_LANE)]:
        group = sorted(by_lane[name], key=lambda m: rank.get(m.name, len(rank)))
        names = tuple(m.name for m in group)
        if name == MAIN_LANE or not group:
            lanes[name] = Lane(name, names)
            continue
        everies = sorted({m.every for m in group})
        if len(everies) > 1:
            which = ", ".join(f"{m.name} every {m.every}" for m in group)
            raise ConfigurationError(
                f"lane {name!r} mixes rates ({which}): a lane other than main runs all its "
                "components at one rate (the loop's: lock step; or every N > 1: logical "
                "execution time); give them one rate, or put them in different lanes"
            )
        every = everies[0]
        phases = sorted({m.phase for m in group if m.phase is not None})
        if len(phases) > 1:
            raise ConfigurationError(
                f"lane {name!r}: its components give different phases ({phases}); a lane on "
                "logical execution time is released once per period: give one phase or none"
            )
        lanes[name] = Lane(name, names, every, phases[0] if phases else 0)
    return lanes


@dataclass(frozen=True)
class Connection:
    """One input's topic and where its value comes from, for the lane plan."""

    topic: str
    producer: str  # component
    consumer: str  # component


def lane_steps(
    lane: str,
    lanes: Mapping[str, Lane],
    members: Mapping[str, Member],
    order: Sequence[str],
    connections: Iterable[Connection],
    mirror: Mapping[str, str] | None = None,
) -> list[Step]:
    """The steps of one lane: its components' updates in the global order, and the
    handovers of the values that cross into and out of it.

    A reader in a lock-step lane gets a crossing value right before its update: this
    iteration's if its producer comes before it in the order, else the previous
    iteration's (an ``is_first`` edge), as the sequential run would. A producer hands
    its value over right after its update, in every iteration (also when it is
    skipped, so readers never wait in vain). A LET lane takes its inputs first and
    hands its outputs over last; a reader of a LET lane's output takes the new value
    at the start of each of its windows.

    ``mirror`` (topic -> producing component) are topics the main lane receives at
    the end of each iteration whoever reads them (a trace of every topic): their
    value after the iteration, or a LET lane's visible one.
    """
    here = lanes[lane]
    rank = {n: k for k, n in enumerate(order)}
    lane_of_member = {n: m.lane for n, m in members.items()}
    reads: dict[str, list[Connection]] = {}  # consumer -> crossing inputs
    sent: dict[str, set[str]] = {}  # producer -> crossing topics it writes
    let_in: dict[str, str] = {}  # topic -> producing LET lane, read here
    takes: dict[str, str] = {}  # topic -> producing lane, read by this LET lane
    let_out: set[str] = set()
    for c in connections:
        source, target = lane_of_member[c.producer], lane_of_member[c.consumer]
        if source == target:
            continue
        if source == lane:
            if here.let:
                let_out.add(c.topic)
            else:  # to lock-step readers and to LET lanes' releases alike
                sent.setdefault(c.producer, set()).add(c.topic)
        if target == lane:
            if lanes[source].let:
                let_in[c.topic] = source
            elif here.let:
                takes[c.topic] = source
            else:
                reads.setdefault(c.consumer, []).append(c)
    at_end: dict[str, str] = {}  # topic -> producing lane: the main lane's mirrors
    for topic, producer in (mirror or {}).items():
        source = lane_of_member.get(producer, MAIN_LANE)
        if source == MAIN_LANE:
            continue
        if source == lane:
            if here.let:
                let_out.add(topic)
            else:
                sent.setdefault(producer, set()).add(topic)
        elif lane == MAIN_LANE:
            if lanes[source].let:
                let_in[topic] = source
            else:
                at_end[topic] = source
    steps: list[Step] = []
    if here.let:
        steps += [Step(TAKE, t, True, takes[t]) for t in sorted(takes)]
        steps += [Step(LET_IN, t, False, let_in[t]) for t in sorted(let_in)]
        steps += [Step(UPDATE, n) for n in here.members if members[n].scheduled]
        steps += [Step(LET_OUT, t) for t in sorted(let_out)]
        return steps
    steps += [Step(LET_IN, t, False, let_in[t]) for t in sorted(let_in)]
    last: dict[str, bool] = {}  # topic -> the version the local slot holds now
    for name in order:
        if lane_of_member.get(name) != lane:
            continue
        for c in sorted(reads.get(name, ()), key=lambda c: c.topic):
            delayed = rank[name] < rank[c.producer]
            if last.get(c.topic) != delayed:
                last[c.topic] = delayed
                steps.append(Step(RECV, c.topic, delayed, lane_of_member[c.producer]))
        if members[name].scheduled:
            steps.append(Step(UPDATE, name))
        steps += [Step(SEND, t) for t in sorted(sent.get(name, ()))]
    for topic in sorted(at_end):
        if last.get(topic) is not False:
            steps.append(Step(RECV, topic, False, at_end[topic]))
    return steps


class LocalLet:
    """Logical execution time in one process (``rtcf.testing``, an in-process runner):
    the same values as lanes in their own processes, with plain slots.

    A LET lane's inputs read private slots, filled from the topics' slots at its
    release; its outputs write private slots, copied to the slots the other lanes
    read at the start of the window after. It is a step that runs first in every
    iteration, before any component: first every window that ends hands over its
    outputs, then every lane released takes its inputs (so a LET lane reading another
    sees what became visible in the same iteration, as in separate processes).
    """

    __slots__ = ("lanes", "state")

    def __init__(
        self,
        state: LoopState,
        # per LET lane: (every, phase, inputs (topic's slot, private slot),
        #                outputs (private slot, topic's slot))
        lanes: Sequence[
            tuple[int, int, Sequence[tuple[Slot, Slot]], Sequence[tuple[Slot, Slot]]]
        ],
    ) -> None:
        self.state = state
        self.lanes = tuple((e, p, tuple(i), tuple(o)) for e, p, i, o in lanes)

    def __call__(self) -> None:
        i = self.state.iteration
        for every, phase, _, outputs in self.lanes:
            if (i - phase) % every == 0 and i - every >= phase:  # a window ends
                for src, dst in outputs:
                    _copy(src, dst)
        for every, phase, inputs, _ in self.lanes:
            if (i - phase) % every == 0:  # released: inputs as iteration i - 1 left them
                for src, dst in inputs:
                    _copy(src, dst)


def _copy(src: Slot, dst: Slot) -> None:
    value = src.value
    # a Serialized is rewritten in place by its writer: hand over what lanes in their
    # own processes hand over, the message of its bytes now
    dst.value = value.to_message() if type(value) is Serialized else value
    dst.seq = src.seq
    dst.iteration = src.iteration
