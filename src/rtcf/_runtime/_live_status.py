"""What a runner's status line shows while its loop runs, and when it is said.

:class:`LiveStatus` is the line (iterations, overruns, jitter, faults, who may change
the runner); the CLI prints it and the bridges publish it on /diagnostics.
:class:`LiveReport` says it while a command waits (every STATUS_EVERY_S to the
status line, every DIAGNOSTICS_EVERY_S to the bridge) and counts the loop's starts.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from .._core._timing import TimingAggregate

STATUS_EVERY_S = 0.5
DIAGNOSTICS_EVERY_S = 1.0


@dataclass
class LiveStatus:
    """What the status line shows while the loop runs."""

    iterations: int
    overruns: int
    jitter_p999_us: float
    calc_p999_us: float
    calc_max_us: float
    log_records_dropped: int
    elapsed_s: float
    faults: int = 0  # component failures a policy contained (on_error deactivate/restart)
    # who may change the runner: "lock L", "allowed modules ..." (empty: anyone, anything)
    access: str = ""
    # how often the loop started: a load or unload stops it and starts it again on its
    # time grid; a refused request must not (docs/security.md)
    starts: int = 0
    # inputs past their deadline now (component.input), and how many times any passed it
    past_deadline: tuple[str, ...] = ()
    deadline_misses: int = 0
    # commands the hardware's limits clamped, and those they refused (never passed on)
    commands_clamped: int = 0
    commands_refused: int = 0


class LiveReport:
    """The status line and diagnostics of one runner while its loop runs, and how
    often the loop started (LiveStatus.starts)."""

    def __init__(self, on_status: Callable[[LiveStatus], None] | None) -> None:
        self.on_status = on_status
        self.starts = 0
        self.started_at: float | None = None  # when the loop last started
        self._last_status = self._last_diagnostics = 0.0  # of the command waited for

    def begin(self) -> None:
        """A command begins: the first line comes one interval after it."""
        self._last_status = self._last_diagnostics = time.monotonic()

    def started(self) -> None:
        self.starts += 1
        self.started_at = time.monotonic()

    def poll(
        self,
        status: Callable[[], LiveStatus],
        diagnostics: Callable[[LiveStatus], None] | None,
    ) -> None:
        """A polling interval of a command while the loop runs: say what is due."""
        if self.on_status is not None:
            now = time.monotonic()
            if now - self._last_status >= STATUS_EVERY_S:
                self._last_status = now
                self.on_status(status())
        if diagnostics is not None:
            now = time.monotonic()
            if now - self._last_diagnostics >= DIAGNOSTICS_EVERY_S:
                self._last_diagnostics = now
                diagnostics(status())

    def status(
        self, aggregate: TimingAggregate, *, log_records_dropped: int, faults: int, access: str,
        deadlines: tuple[tuple[str, ...], int] = ((), 0),
        commands: Sequence[int] = (0, 0),
    ) -> LiveStatus:
        started = self.started_at if self.started_at is not None else time.monotonic()
        return LiveStatus(
            iterations=aggregate.rows,
            overruns=aggregate.overruns,
            jitter_p999_us=aggregate.jitter.quantile(0.999) / 1e3,
            calc_p999_us=aggregate.calc.quantile(0.999) / 1e3,
            calc_max_us=aggregate.calc.quantile(1.0) / 1e3,
            log_records_dropped=log_records_dropped,
            elapsed_s=time.monotonic() - started,
            faults=faults,
            access=access,
            starts=self.starts,
            past_deadline=deadlines[0],
            deadline_misses=deadlines[1],
            commands_clamped=commands[0],
            commands_refused=commands[1],
        )


def live_aggregate(aggregate: TimingAggregate | None, span: Any) -> TimingAggregate:
    """A run's timing so far: with lanes (``span``) the loop's as a whole."""
    aggregate = aggregate or TimingAggregate()
    return span.snapshot(aggregate) if span is not None else aggregate


def live_status_of(runner: Any) -> LiveStatus:
    """A WorkerRunner's status now: its timing, logs, faults, deadlines and commands,
    with its lanes' workers'."""
    workers = (runner, *runner._lanes.workers.values())
    return runner._report.status(
        runner._live_aggregate(),
        log_records_dropped=runner.log_records_dropped,
        faults=runner._process.faults,
        access=runner.admission.access,
        deadlines=runner.past_deadline(),
        commands=[sum(c) for c in zip(*(w._process.command_words for w in workers),
                                      strict=True)],
    )
