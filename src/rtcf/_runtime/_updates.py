"""Changes the supervisor sends its worker between iterations, and their answers.

Tunable values, log levels and lifecycle transitions cross to the worker as update
records on one ring; the loop applies them at the start of its next iteration
(between runs: before the worker's next command). Any thread may ask; a full ring
keeps the newest value of each key in a backlog that the main thread sends again
when it drains. A transition's outcome comes back on the outcome ring: the answer to
the caller who waits for it, and news for the listeners (a bridge's transition
events) and for the components' lifecycle states.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from .._core._errors import RtcfError
from .._core._lifecycle import (
    CONFIGURE,
    OUTCOME_RECORD_SIZE,
    OUTCOME_RING_RECORDS,
    REFUSED,
    STATE_LABELS,
    UNDONE,
    UNKNOWN,
    TransitionOutcome,
    decode_outcome,
    refused,
)
from .._core._log import LogLevel
from .._core._rings import Ring
from .._core._tunables import (
    BATCH,
    LIFECYCLE,
    LOG_LEVEL,
    PARAMETER,
    UPDATE_RECORD_SIZE,
    UPDATE_RING_RECORDS,
    encode_update,
)
from ._loaded import LoadedComponents
from ._shm import Segment


class WorkerUpdates:
    """The update and outcome rings of one worker, the backlog and the transitions
    waited for; under the lock of the ``loaded`` components (whose states it sets)."""

    def __init__(self, loaded: LoadedComponents) -> None:
        self.loaded = loaded
        self.lock = loaded.lock
        # updates for the worker: the bridge thread sets, the main thread retries
        self._ring: Ring | None = None
        # (a batch of transitions is a tuple: the ring takes all of it at once, or none)
        self._backlog: dict[tuple[int, str, str], bytes | tuple[bytes, ...]] = {}
        # lifecycle transitions: asked for by any thread, answered by the worker on the
        # outcome ring, which the main thread drains (pump)
        self._outcomes: Ring | None = None
        self.pending: dict[int, PendingTransition] = {}
        self._request_numbers = itertools.count(1)
        # told every transition a component went through (a bridge: transition events)
        self.listeners: list[Callable[[str, TransitionOutcome], None]] = []
        # loaded unconfigured, then configured: its ports and tunables to describe again
        self.configured: set[str] = set()

    def open(self, segment: Callable[[int, str], Segment]) -> Segment:
        """One segment, two rings: updates to the worker, lifecycle outcomes back."""
        first = Ring.nbytes(UPDATE_RING_RECORDS, UPDATE_RECORD_SIZE)
        updates = segment(
            first + Ring.nbytes(OUTCOME_RING_RECORDS, OUTCOME_RECORD_SIZE), "rtcf-updates"
        )
        self._ring = Ring.create(updates.buf, UPDATE_RING_RECORDS, UPDATE_RECORD_SIZE)
        view = updates.buf[first:]
        self._outcomes = Ring.create(view, OUTCOME_RING_RECORDS, OUTCOME_RECORD_SIZE)
        view.release()
        return updates

    def pump(self) -> None:
        """Send what waits in the backlog, and hand out the outcomes (main thread)."""
        if self._backlog:
            with self.lock:
                self._send_backlog()
        if self._outcomes is not None and len(self._outcomes):
            self._drain_outcomes()

    def post(self, key: tuple[int, str, str], value: Any) -> None:
        """Send a new value (under the lock)."""
        # the newest value of each key wins; older ones still waiting are replaced
        self._backlog.pop(key, None)
        self._backlog[key] = encode_update(key[0], key[1], key[2], value)
        self._send_backlog()

    def _send_backlog(self) -> None:
        ring = self._ring
        if ring is None:
            return
        for key in list(self._backlog):
            record = self._backlog[key]
            sent = ring.push(record) if isinstance(record, bytes) else ring.push_all(list(record))
            if not sent:
                return  # full: pump() tries again; the worker takes them between iterations
            del self._backlog[key]

    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        """Validate a new value here, then hand it to the worker for the next iteration."""
        spec = self.loaded.tunable(component, name)
        value = spec.validate(value)
        with self.lock:
            self.loaded.set_value(component, name, value)
            self.post((PARAMETER, spec.component, name), value)
        return value

    def set_log_level(self, component: str, level: int | str) -> None:
        """Filter the component's records in the worker from the next iteration on."""
        info = self.loaded.find(component)
        number = LogLevel[level.upper()] if isinstance(level, str) else int(level)
        with self.lock:
            info["log_level"] = number
            self.post((LOG_LEVEL, str(info["name"]), ""), number)

    def take_configured(self) -> list[str]:
        """The components loaded unconfigured that their first configure declared ports
        and tunables for, since the last call (to describe again); the outcomes the
        worker sent are taken first (main thread)."""
        self.pump()
        with self.lock:
            names, self.configured = sorted(self.configured), set()
        return names

    def unloaded(self, component: str) -> None:
        """The worker unloaded ``component``: its entry and its updates go, and the
        transitions that wait for it are refused."""
        with self.lock:
            self.loaded.components.pop(component, None)
            self._backlog = {k: v for k, v in self._backlog.items() if k[1] != component}
            dropped = [n for n, p in self.pending.items() if p.component == component]
        for number in dropped:
            self.answer(number, refused(UNKNOWN, f"component {component!r} was unloaded"))

    # -- lifecycle ----------------------------------------------------------------------
    def send_transitions(
        self, transitions: Sequence[tuple[str, int | str]], strict: bool = False
    ) -> list[tuple[int, PendingTransition]]:
        """Send transitions as one batch: the worker reads them all at the start of the
        same iteration (the ring commits them at once), and applies them in this order;
        ``strict``: all or none, undone in that iteration if one fails (a BATCH record
        first says how many follow)."""
        if len(transitions) + strict > UPDATE_RING_RECORDS:
            raise RtcfError(
                f"{len(transitions)} lifecycle transitions at once: a worker takes "
                f"{UPDATE_RING_RECORDS - strict} at most in one iteration; ask for fewer"
            )
        asked: list[tuple[int, PendingTransition]] = []
        with self.lock:
            records = [encode_update(BATCH, "", "strict", len(transitions))] if strict else []
            for full, transition in transitions:
                number = next(self._request_numbers)
                pending = PendingTransition(full, transition)
                self.pending[number] = pending
                asked.append((number, pending))
                records.append(encode_update(LIFECYCLE, full, str(transition), number))
            # a key of its own: unlike values, transitions are never merged; no
            # component's (an unload drops no part of a batch: the worker refuses it)
            self._backlog[(LIFECYCLE, "", f"#{asked[0][0]}")] = tuple(records)
            self._send_backlog()
        return asked

    def wait(
        self, number: int, pending: PendingTransition, until: float, timeout: float
    ) -> TransitionOutcome:
        """The outcome of request ``number``, or a refusal once ``until`` (monotonic,
        ``timeout`` after the request) passed."""
        if not pending.done.wait(max(0.0, until - time.monotonic())):
            with self.lock:
                self.pending.pop(number, None)
            return refused(
                UNKNOWN,
                f"component {pending.component!r}: no answer to {pending.transition!r} within "
                f"{timeout:g} s (the loop did not reach its next iteration); it may still happen",
            )
        assert pending.outcome is not None
        return pending.outcome

    def _drain_outcomes(self) -> None:
        ring = self._outcomes
        assert ring is not None
        while True:
            record = ring.pop()
            if record is None:
                return
            number, component, outcome = decode_outcome(record)
            # a negative number: the answer only (a STRICT switch's: its changes came
            # before it as news)
            self.answer(abs(number), outcome, component, news=number >= 0)

    def answer(self, number: int, outcome: TransitionOutcome, component: str = "",
               news: bool = True) -> None:
        """An outcome: the answer to request ``number``, or (0, or a request whose caller
        gave up waiting) a change all the same: the cache and the listeners hear of it
        (unless not ``news``)."""
        news = news and outcome.result not in (REFUSED, UNDONE)
        with self.lock:
            pending = self.pending.pop(number, None) if number else None
            if pending is not None:
                component = pending.component
            if news:
                self.loaded.set_lifecycle(component, STATE_LABELS[outcome.end])
                info = self.loaded.components.get(component)
                if (outcome.transition == CONFIGURE and outcome.ok and info is not None
                        and info.get("configured") is False):
                    self.configured.add(component)
        if news and component:
            for listener in self.listeners:
                listener(component, outcome)
        if pending is not None:
            pending.outcome = outcome
            pending.done.set()

    def close(self) -> None:
        """The worker is gone: no more rings; every transition still waited for is
        refused."""
        if self._ring is not None:
            with self.lock:
                self._ring.close()
                self._ring = None
        if self._outcomes is not None:
            self._outcomes.close()
            self._outcomes = None
        for number in list(self.pending):
            self.answer(number, refused(UNKNOWN, "the runner is shutting down"))


def change_states(
    transitions: Sequence[tuple[WorkerUpdates, Callable[[], None], str, int | str]],
    timeout: float, strict: bool = False,
) -> list[TransitionOutcome]:
    """Transitions of components in one or several workers (``(updates, hand_over,
    component, transition)`` each), applied together: each worker gets its share as one
    batch, which its loop applies at the start of its next iteration, in the order
    given (``strict``: all or none, in that iteration); then wait for every outcome (in
    the order given) for ``timeout`` at most."""
    shares: dict[int, list[int]] = {}  # id(updates) -> the transitions' indices
    for k, (updates, *_) in enumerate(transitions):
        shares.setdefault(id(updates), []).append(k)
    asked: dict[int, tuple[WorkerUpdates, int, PendingTransition]] = {}
    for indices in shares.values():
        updates = transitions[indices[0]][0]
        sent = updates.send_transitions([transitions[k][2:] for k in indices], strict)
        for k, (number, pending) in zip(indices, sent, strict=True):
            asked[k] = (updates, number, pending)
    for indices in shares.values():
        transitions[indices[0]][1]()  # hand over
    until = time.monotonic() + timeout
    return [updates.wait(number, pending, until, timeout)
            for updates, number, pending in (asked[k] for k in range(len(transitions)))]


class PendingTransition:
    """A transition a caller waits for."""

    def __init__(self, component: str, transition: int | str = "") -> None:
        self.component = component
        self.transition = transition
        self.done = threading.Event()
        self.outcome: TransitionOutcome | None = None


def queued_first_configure(
    requests: Any, components: dict[str, dict[str, Any]],
    transitions: Sequence[tuple[str, int | str]], on_main: bool,
) -> TransitionOutcome | None:
    """The first configure of a component loaded unconfigured (it declares its ports: the
    graph is resolved again), asked for from a thread other than the main one (``not
    on_main``): served by the runner's request queue (``requests``, :mod:`._requests`)
    between two runs, as a load is, so that the next run maps the new ports. None when
    it is not one, or no queue serves."""
    if on_main or requests is None or len(transitions) != 1:
        return None
    component, transition = transitions[0]
    info = components.get("/" + component.lstrip("/"))
    if (str(transition) not in ("configure", str(CONFIGURE)) or info is None
            or info.get("configured") is not False):
        return None
    full = str(info["name"])
    req = requests.submit("configure", full)
    outcome: TransitionOutcome | None = req.outcome
    return outcome or refused(UNKNOWN, f"component {full!r}: configure: {req.reason}")
