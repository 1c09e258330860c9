"""Lanes in worker processes of their own: the shared memory that ties them together.

One anonymous segment per run (the supervisor creates it, every lane's worker maps
it) holds a few words every lane reads and writes, and one channel per topic that
crosses lanes. A channel has :data:`DEPTH` entries, indexed by the version they
hold (a lock-step producer's iteration, a LET lane's release), each written
seqlock-style: the stamp goes to -1, then the value (encoded by the port type's
codec), then the stamp to the version. A reader in another lane waits for exactly
the version the sequential run would read, so the values are the sequential run's,
bit for bit. In real time the wait is bounded by the end of the reader's period
(then: a counted late arrival, and the previous value stays); on a simulated clock
it is not, and every lane waits at the end of each iteration until the others have
done theirs (the lanes of a ``--sim`` run take turns, and give the same values).

The words tie the lanes' runs together: they start from one iteration and one
deadline (the main lane picks them once every lane is ready), and a lane that stops
(asked to, or failing) says after which iteration, so the others stop there too.

This module holds both sides: the layout the supervisor computes, and the steps a
worker's runner binds into its plan (:attr:`rtcf._core._runner.Runner.handovers`): on
the compiled hot path rtcf._core._compiled.Handover, else the classes at the end of
this module, which do the same in Python (tests/unit/test_lane_handovers.py runs both).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Mapping, MutableSequence, Sequence
from dataclasses import dataclass
from typing import Any

from .._core._errors import ConfigurationError
from .._core._executor import ABORT, STOP, StopFlag
from .._core._hotpath import Handover
from .._core._lanes import LET_IN, LET_OUT, RECV, SEND, TAKE, Lane, Step
from .._core._ports import OutputPort, Slot
from .._core._rings import FENCED, acquire_fence, release_fence
from ._codec import codec_for

DEPTH = 4  # versions a channel keeps: a reader may fall this far behind its producer
NEVER = sys.maxsize  # the stop word when no lane stops

# words of the header (int64 each)
W_STOP_AT = 0  # the last iteration any lane runs (NEVER: none asked)
W_REASON = 1  # why: STOP, CONTROL or ABORT (the lanes stop with the same reason)
W_GO = 2  # the run number, once the main lane has set where the run starts
W_START_ITERATION = 3  # the main lane's first iteration of the run
W_START_NS = 4  # its deadline
W_ORIGIN_NS = 5  # the time grid's origin (the first run's start)
W_FIRST = 6  # the first iteration this segment carries values of (NEVER: none yet)
HEADER_WORDS = 8
# per lane
L_READY = 0  # the run number, once the lane is ready to start it
L_LAST = 1  # its last iteration (ready) / the last it finished (running)
L_NOW = 2  # its clock when ready (a simulated clock's time)
L_TAKEN = 3  # a LET lane: the last release whose inputs it no longer needs
LANE_WORDS = 4
ENTRY_WORDS = 4  # stamp, seq, iteration, n (n = -1: the slot was never written)


@dataclass(frozen=True)
class Channel:
    """One topic that crosses lanes, in the run's segment."""

    topic: str
    lane: str  # its producer's
    step: int  # versions are iterations (1) or a LET lane's releases (every)
    max_size: int  # bytes of one value
    offset: int  # of its first entry, in bytes

    @property
    def entry_bytes(self) -> int:
        return 8 * ENTRY_WORDS + -(-self.max_size // 8) * 8


@dataclass(frozen=True)
class LaneLayout:
    """Where everything is in the run's segment, as every process sees it."""

    lanes: tuple[str, ...]  # main first
    kinds: tuple[tuple[int, int], ...]  # per lane: (every, phase); every 1: lock step
    channels: tuple[Channel, ...]
    size: int

    def index(self, lane: str) -> int:
        return self.lanes.index(lane)


def layout(lanes: Mapping[str, Lane], sends: Mapping[str, tuple[str, int]]) -> LaneLayout:
    """The layout of a run: ``sends`` maps each crossing topic to its producing lane
    and the bytes of one value."""
    names = tuple(lanes)
    offset = 8 * (HEADER_WORDS + LANE_WORDS * len(names))
    channels = []
    for topic in sorted(sends):
        lane, max_size = sends[topic]
        channel = Channel(topic, lane, lanes[lane].every, max_size, offset)
        channels.append(channel)
        offset += DEPTH * channel.entry_bytes
    kinds = tuple((lanes[n].every, lanes[n].phase) for n in names)
    return LaneLayout(names, kinds, tuple(channels), offset)


def value_size(port: OutputPort[Any], lane: str, readers: str = "another lane") -> int:
    """The bytes a value of a crossing topic may take; a clear error when its type
    cannot cross processes."""
    codec = codec_for(port.type)
    if codec is None:
        raise ConfigurationError(
            f"topic {port.topic!r} crosses from lane {lane!r} ({port.component}) to "
            f"{readers}, but its type {port.type.__module__}.{port.type.__qualname__} "
            "cannot cross processes: lanes hand over float, int, bool, str, numpy arrays "
            "and ROS messages; use one of them, or put producer and readers in one lane"
        )
    return codec.max_size


EMPTY = -(2**62)  # the stamp of an entry never written (below every version)


def init_words(buf: memoryview, lanes: LaneLayout) -> None:
    """A fresh segment: no lane stops yet, no entry holds a version."""
    words = buf[: lanes.size].cast("q")
    words[W_STOP_AT] = NEVER
    words[W_FIRST] = NEVER
    for c in lanes.channels:
        for k in range(DEPTH):
            words[(c.offset + k * c.entry_bytes) // 8] = EMPTY
    words.release()


def reset_stop(buf: memoryview) -> None:
    """Before a run (no lane runs): forget the last run's stop."""
    words = buf[: 8 * HEADER_WORDS].cast("q")
    words[W_REASON] = 0
    words[W_STOP_AT] = NEVER
    words.release()


def abort_all(buf: memoryview) -> None:
    """A lane is gone (the supervisor saw it die): every other lane stops at once,
    through its safe stops."""
    words = buf[: 8 * HEADER_WORDS].cast("q")
    words[W_REASON] = ABORT
    if FENCED:
        release_fence()
    words[W_STOP_AT] = -1
    words.release()


_yield = getattr(os, "sched_yield", lambda: time.sleep(0))


def _nap() -> None:
    time.sleep(50e-6)


class LaneLink:
    """A worker's side of the lanes of a run: its handover steps, what it does after
    each iteration, and how it starts."""

    def __init__(
        self,
        buf: memoryview,
        lanes: LaneLayout,
        lane: str,
        *,
        simulated: bool,
        period_ns: int,
        nap: bool = False,
    ) -> None:
        self.layout = lanes
        self.lane = lane
        self.index = lanes.index(lane)
        self.every, self.phase = lanes.kinds[self.index]
        self.simulated = simulated
        self.period_ns = period_ns
        # how a wait lets others run: yield the CPU; or, where it has no bound while the
        # lanes run at a real-time priority (/clock time), sleep, so that a spinning lane
        # cannot starve the supervisor that brings /clock (nor a lane sharing its CPU)
        self.pause: Callable[[], object] = _nap if nap else _yield
        self.buf = buf
        self.words: memoryview = buf.cast("q")
        self.base = HEADER_WORDS + LANE_WORDS * self.index  # this lane's words
        self.channels = {c.topic: c for c in lanes.channels}
        # (label, a lock-step send, the handover bound into the plan): the compiled
        # one where it is built (rtcf._core._compiled.Handover), else the classes below
        self.steps: list[tuple[str, bool, Any]] = []
        self.state: Any = None
        self.stop: StopFlag | None = None  # the stop word the supervisor writes
        # the lane's own stop word, the one its loop reads: only this lane sets it, in
        # after(), so a request that arrives later cannot end the loop where the
        # other lanes do not know it (they would wait for it for ever)
        self.decision = StopFlag()
        self.origin_ns = 0
        self.now: Callable[[], int] = time.monotonic_ns
        self.stopped_here = False  # it set the stop word: another lane stopped
        # the other lanes: (their words' base, every, phase)
        self.others = [
            (HEADER_WORDS + LANE_WORDS * k, every, phase)
            for k, (every, phase) in enumerate(lanes.kinds)
            if k != self.index
        ]

    # -- binding (the runner's compile) -----------------------------------------------
    def bind(self, step: Step, port: OutputPort[Any]) -> Callable[[], object]:
        channel = self.channels.get(step.name)
        if channel is None:  # the layout and the plan disagree: a bug, say which
            raise ConfigurationError(
                f"lane {self.lane!r}: no channel for {step.label!r} in the run's layout"
            )
        codec = codec_for(port.type)
        assert codec is not None  # value_size() refused it before the layout was made
        entries = []
        for k in range(DEPTH):
            at = channel.offset + k * channel.entry_bytes
            entries.append((at // 8, self.buf[at + 8 * ENTRY_WORDS : at + channel.entry_bytes]))
        producer = self.layout.index(channel.lane)  # its words, and its (every, phase)
        source = HEADER_WORDS + LANE_WORDS * producer + L_LAST
        send = step.kind in (SEND, LET_OUT)
        if step.kind not in (SEND, LET_OUT, RECV, TAKE, LET_IN):
            raise ConfigurationError(f"lane {self.lane!r}: unknown handover {step.kind!r}")
        mode = _SEND if send else _LET_IN if step.kind == LET_IN else _RECV
        delayed = 1 if (step.delayed or step.kind == TAKE) else 0
        code: Any = codec.encode if send else codec.decode_buffer()
        every, phase = self.layout.kinds[producer]
        assert self.state is not None, "bound() before bind()"
        handover: Any
        if Handover is not None:
            handover = Handover(
                mode, self.words, tuple(entries), self.state, port._slot, codec.kind, code,
                channel.max_size, delayed, source, channel.step, every, phase,
                self.simulated, self.period_ns,
                None if self.now is time.monotonic_ns else self.now, self.pause is _nap,
            )
        else:
            args = (self, step, port._slot, channel, entries, code, source)
            if mode == _LET_IN:
                handover = _LetIn(*args, every, phase)
            else:
                handover = (_Send, _Recv)[mode](*args)
        self.steps.append((step.label, step.kind == SEND, handover))
        return handover

    def bound(self, state: Any, stop: StopFlag, now: Callable[[], int]) -> None:
        """The runner's loop state, stop word and clock, once its plan is compiled."""
        self.state = state
        self.stop = stop
        self.now = now

    # -- starting together ------------------------------------------------------------
    def begin(self, run: int, next_deadline_ns: int | None, origin_ns: int | None,
              resume: Callable[[int, int, int], None], iterations: int | None = None) -> None:
        """Wait until every lane is ready for run number ``run``, then start where the
        main lane says: the same first iteration and deadline, on one grid. The main
        lane's ``iterations`` end every lane's run after the same iteration."""
        words, base, state = self.words, self.base, self.state
        assert state is not None
        if state.iteration >= 0:  # it ran before: what its last iteration left, for a
            for _, lock_step_send, h in self.steps:  # delayed reader's first iteration
                if lock_step_send:  # (a new segment after a load has none)
                    h()
        self.decision.clear()
        words[base + L_LAST] = state.iteration
        # said before it says ready, like L_LAST: the main lane starts the run once every
        # lane is ready, and a simulated clock's barrier reads this word from its first
        # iteration on; set only after the start (below) it was a fresh segment's 0
        # there, "release 0 taken", and the main lane ran that window ahead, over the
        # entries the LET lane's first take was still to read (counted lost)
        words[base + L_TAKEN] = state.iteration
        words[base + L_NOW] = self.now() if self.simulated else 0
        if FENCED:
            release_fence()
        words[base + L_READY] = run
        if self.index == 0:
            lanes = [HEADER_WORDS + LANE_WORDS * k for k in range(len(self.layout.lanes))]
            while any(words[b + L_READY] != run for b in lanes):
                self._pause()
            if FENCED:
                acquire_fence()
            lock_step = [
                b for b, (every, _) in zip(lanes, self.layout.kinds, strict=True) if every == 1
            ]
            m = max(words[b + L_LAST] for b in lock_step) + 1
            if self.simulated:
                start = max(words[b + L_NOW] for b in lanes)
                if next_deadline_ns is not None:
                    start = max(start, next_deadline_ns)
            else:  # far enough ahead for every lane to see it and go to sleep
                start = time.monotonic_ns() + max(5_000_000, 2 * self.period_ns)
            origin = origin_ns if origin_ns is not None else start
            if words[W_FIRST] == NEVER:
                words[W_FIRST] = m
            if iterations is not None:
                words[W_REASON] = STOP
                words[W_STOP_AT] = m + iterations - 1
            reason = self.stop.cell[0] if self.stop is not None else 0
            if reason:  # asked to stop before the run began (a request came meanwhile):
                words[W_REASON] = max(words[W_REASON], reason)  # no lane runs an iteration
                words[W_STOP_AT] = m - 1
            words[W_START_ITERATION] = m
            words[W_START_NS] = start
            words[W_ORIGIN_NS] = origin
            if FENCED:
                release_fence()
            words[W_GO] = run
        else:
            while words[W_GO] != run:
                if words[W_REASON] == ABORT:  # the run ended before it began
                    raise Aborted()
                self._pause()
            if FENCED:
                acquire_fence()
        m, start, origin = words[W_START_ITERATION], words[W_START_NS], words[W_ORIGIN_NS]
        self.origin_ns = origin
        every, phase = self.every, self.phase
        first = m + (phase - m) % every  # this lane's first iteration (a LET release)
        resume(first, start + (first - m) * self.period_ns, origin)
        words[base + L_LAST] = first - every
        words[base + L_TAKEN] = first - every
        if words[W_STOP_AT] < first:  # the run ends before this lane's first iteration
            self.decision.cell[0] = words[W_REASON] or STOP

    def _pause(self) -> None:
        stop = self.stop
        if stop is not None and stop.cell[0] == ABORT:
            raise Aborted()
        time.sleep(0.0001)

    # -- every iteration ----------------------------------------------------------------
    def feeder(self) -> None:
        """First in each iteration: the iteration before is over (also one a failure
        ended early): a reader waiting for a value of it stops waiting."""
        state = self.state
        self.words[self.base + L_LAST] = state.iteration - self.every

    def after(self) -> None:
        """After each iteration: say it is done, stop with the other lanes, and on a
        simulated clock wait until they are done too."""
        words, state = self.words, self.state
        i = state.iteration
        cell = self.decision.cell
        # asked to stop (the supervisor's word, or the runner's own): this lane stops
        # after i, and so do the others; said before this iteration is said done, so
        # a lane that waits for it sees the stop when its wait ends
        reason = self.stop.cell[0] or cell[0]  # type: ignore[union-attr]
        if reason:
            cell[0] = reason
            if words[W_STOP_AT] > i:
                words[W_REASON] = max(words[W_REASON], reason)
                if FENCED:
                    release_fence()
                words[W_STOP_AT] = i
        if FENCED:
            release_fence()
        words[self.base + L_LAST] = i
        words[self.base + L_TAKEN] = i  # (a LET lane's release is over: its inputs too)
        if reason:
            return
        nxt = i + self.every
        if words[W_STOP_AT] < nxt:
            cell[0] = words[W_REASON] or STOP
            self.stopped_here = True
            return
        if self.simulated:
            self._barrier(nxt, cell)

    def _barrier(self, nxt: int, cell: MutableSequence[int] | memoryview) -> None:
        """Wait until every other lane has done iteration ``nxt - 1`` (a LET lane: has
        taken the inputs of its releases up to it)."""
        words = self.words
        for base, every, phase in self.others:
            if every == 1:
                word, want = base + L_LAST, nxt - 1
            else:
                word, want = base + L_TAKEN, nxt - 1 - (nxt - 1 - phase) % every
            while words[word] < want:
                if words[W_STOP_AT] < nxt:
                    cell[0] = words[W_REASON] or STOP
                    self.stopped_here = True
                    return
                self.pause()
        if FENCED:
            acquire_fence()
        if words[W_STOP_AT] < nxt:  # a lane that stopped said so before it said done
            cell[0] = words[W_REASON] or STOP
            self.stopped_here = True

    def failed(self) -> None:
        """This lane's loop ended on an error: the others stop, through their safe
        stops, after the iteration they are in."""
        words = self.words
        words[W_REASON] = ABORT
        i = self.state.iteration if self.state is not None else 0
        if FENCED:
            release_fence()
        if words[W_STOP_AT] > i:
            words[W_STOP_AT] = i

    def counts(self) -> dict[str, dict[str, int]]:
        """Per handover topic: values that came late or were lost (real time), and
        the windows a LET lane had not finished (LET overruns)."""
        out: dict[str, dict[str, int]] = {}
        for label, _, h in self.steps:
            c = {k: v for k in ("late", "lost", "let_overruns") if (v := getattr(h, k, 0))}
            if c:
                out[label] = c
        return out

    def release(self) -> None:
        for _, _, h in self.steps:
            h.release()
        self.steps.clear()
        self.words.release()


class Aborted(Exception):
    """The run ended (a signal, a lane gone) before every lane was ready."""


_SEND, _RECV, _LET_IN = 0, 1, 2  # a handover's mode (rtcf._core._compiled.Handover's)


class _Handover:
    """The Python path's handovers (rtcf._core._compiled.Handover is the same in C)."""

    __slots__ = ("entries", "link", "slot", "source", "step", "words")

    def __init__(self, link: LaneLink, step: Step, slot: Slot, channel: Channel,
                 entries: Sequence[tuple[int, memoryview]], source: int) -> None:
        self.link = link
        self.words = link.words
        self.slot = slot
        self.step = channel.step
        self.entries = tuple(entries)
        self.source = source  # the producer lane's L_LAST word

    def release(self) -> None:
        for _, view in self.entries:
            view.release()
        self.entries = ()


class _Send(_Handover):
    """After the producer (in every iteration): its slot, stamped with the version."""

    __slots__ = ("encode", "too_big")

    def __init__(self, link: LaneLink, step: Step, slot: Slot, channel: Channel,
                 entries: Sequence[tuple[int, memoryview]], encode: Callable[[Any], bytes],
                 source: int) -> None:
        super().__init__(link, step, slot, channel, entries, source)
        self.encode = encode
        self.too_big = channel.max_size

    def __call__(self) -> None:
        v = self.link.state.iteration
        w, payload = self.entries[(v // self.step) % DEPTH]
        words = self.words
        slot = self.slot
        data = b""
        n = -1
        if slot.seq:  # the value first: one that cannot be encoded leaves the entry
            data = self.encode(slot.value)
            n = len(data)
            if n > self.too_big:
                raise ValueError(
                    f"a value of {n} bytes is larger than a lane's channel holds "
                    f"({self.too_big}); send less per iteration"
                )
        words[w] = -1  # being written: a reader that read this entry meanwhile drops it
        if FENCED:
            release_fence()
        if n >= 0:
            payload[:n] = data
        words[w + 1] = slot.seq
        words[w + 2] = slot.iteration
        words[w + 3] = n
        if FENCED:
            release_fence()
        words[w] = v


class _Recv(_Handover):
    """Before the first reader: the producer's value of this iteration (or of the last,
    delayed; a LET lane takes the last at its release), into the readers' slot."""

    __slots__ = ("decode", "delayed", "late", "lost")

    def __init__(self, link: LaneLink, step: Step, slot: Slot, channel: Channel,
                 entries: Sequence[tuple[int, memoryview]],
                 decode: Callable[[Any, int], Any], source: int) -> None:
        super().__init__(link, step, slot, channel, entries, source)
        self.decode = decode
        self.delayed = 1 if (step.delayed or step.kind == TAKE) else 0
        self.late = 0
        self.lost = 0

    def __call__(self) -> None:
        v = self.link.state.iteration - self.delayed
        words = self.words
        # before the first value any lane handed over (a delayed reader's first one is
        # what the iteration before the run left: its producer hands it over at begin)
        if v < words[W_FIRST] - self.delayed:
            return
        w, payload = self.entries[(v // self.step) % DEPTH]
        if words[w] != v and not self._wait(v, w):
            return
        self._read(v, w, payload)

    def _read(self, v: int, w: int, payload: memoryview) -> None:
        """Version ``v`` from entry ``w`` into the readers' slot (if it stayed)."""
        words = self.words
        if FENCED:
            acquire_fence()
        seq, it, n = words[w + 1], words[w + 2], words[w + 3]
        value = self.decode(payload, n) if n >= 0 else None
        if FENCED:
            acquire_fence()
        if words[w] != v:  # overwritten while read: the reader fell DEPTH behind
            self.lost += 1
            return
        slot = self.slot
        slot.value = value
        slot.seq = seq
        slot.iteration = it

    def _wait(self, v: int, w: int) -> bool:
        """Wait for version ``v``: True when it is there; False when it will not come
        (the producer stopped, or finished the iteration without it) or, in real time,
        did not come before this iteration's period ended (late)."""
        link = self.link
        words = self.words
        simulated = link.simulated
        limit = 0 if simulated else (
            words[W_ORIGIN_NS] + link.state.time_ns + link.period_ns
        )
        now = link.now
        while True:
            done = words[self.source]
            if FENCED:
                acquire_fence()
            stamp = words[w]
            if stamp == v:
                return True
            if stamp > v:
                self.lost += 1
                return False
            if done >= v or words[W_STOP_AT] < v:
                return False
            if not simulated and now() > limit:
                self.late += 1
                return False
            link.pause()


class _LetIn(_Recv):
    """A reader of a LET lane, first in each iteration: when a window starts, the
    output of the release it closes (in real time only if it is finished: else a LET
    overrun, and the previous window's value stays)."""

    __slots__ = ("every", "last", "let_overruns", "phase")

    def __init__(self, link: LaneLink, step: Step, slot: Slot, channel: Channel,
                 entries: Sequence[tuple[int, memoryview]],
                 decode: Callable[[Any, int], Any], source: int, every: int,
                 phase: int) -> None:
        super().__init__(link, step, slot, channel, entries, decode, source)
        self.every, self.phase = every, phase  # the LET lane's, as LaneLink.bind found them
        self.last = -sys.maxsize
        self.let_overruns = 0

    def __call__(self) -> None:
        link = self.link
        i = link.state.iteration
        every = self.every
        r = i - every
        r -= (r - self.phase) % every  # the last release whose window has ended
        if r == self.last:
            return
        self.last = r
        words = self.words
        if r < words[W_FIRST]:
            return
        w, payload = self.entries[(r // self.step) % DEPTH]
        if words[w] != r:
            if not link.simulated:  # not finished in its window: keep the last value
                self.let_overruns += 1
                return
            if not self._wait(r, w):
                return
        self._read(r, w, payload)
