"""How a policy runs in the loop, checked against what its configuration says it was
trained for: ``control_dt`` (its period) and ``trained_delay`` (its action delay).

The period is ``every`` loop periods. The delay is the one docs/policies.md derives
("The delay: what training must model"): on logical execution time (a lane of its own,
``every`` N > 1) the action computed from the state of iteration ``r - 1`` acts from
iteration ``r + N + 1``: N + 1 loop periods later than inline, where a policy that runs
after the driver acts from the next iteration, as in a simulator's step (no delay).

``control_dt`` must equal the period (to a relative 1e-6). ``trained_delay`` must round
to the same step as the delay it runs with: within half the coarser of the loop's
period and the ``simulation_dt`` it was trained at (a trainer whose physics step is
5 ms models 21 ms as 20 ms: docs/policies.md, "rounded").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ._config import PolicyConfig

ERROR, WARN = "error", "warn"  # ~on_delay_mismatch


@dataclass(frozen=True)
class Timing:
    """How the policy runs: ``every`` iterations of a loop at ``loop_hz``, on LET or not."""

    loop_hz: float
    every: int
    on_let: bool
    lane: str

    @property
    def period(self) -> float:
        return self.every / self.loop_hz

    @property
    def delay(self) -> float:
        """The action delay it runs with [s] (0: none, as inline)."""
        return (self.every + 1) / self.loop_hz if self.on_let else 0.0

    def describe(self) -> str:
        where = "on LET" if self.on_let else "inline"
        return f"{where} in lane {self.lane!r}, every {self.every} at {self.loop_hz:g} Hz"

    def summary(self) -> str:
        """For the configure log line: its period and delay."""
        delay = (f"action delay {_s(self.delay)} ({self.every} + 1 loop periods)"
                 if self.on_let else "no action delay")
        return f"{self.describe()}: period {_s(self.period)}, {delay}"


def period_mismatch(config: PolicyConfig, timing: Timing) -> str | None:
    """The error when ``control_dt`` is not the period the policy runs at, else None."""
    trained = config.control_dt
    if trained is None or math.isclose(trained, timing.period, rel_tol=1e-6, abs_tol=1e-12):
        return None
    field = ("control_dt" if config.control_decimation is None else
             f"control_dt (control_decimation {config.control_decimation:g} x "
             f"simulation_dt {config.simulation_dt:g})")
    fixes = []
    every = trained * timing.loop_hz
    if every >= 1 and math.isclose(every, round(every), rel_tol=1e-6):
        fixes.append(f"every:={round(every)}")
    fixes.append(f"the loop's frequency {timing.every / trained:g} Hz")
    return (f"policy configuration {config.path}: {field} is {_s(trained)}, but the policy "
            f"runs {timing.describe()}, a period of {_s(timing.period)}; run it at the "
            f"period it was trained for ({' or '.join(fixes)}), or, if it was trained at "
            f"{_s(timing.period)}, say so in the YAML (control_dt: {timing.period:g})")


def delay_mismatch(config: PolicyConfig, timing: Timing) -> str | None:
    """The error when ``trained_delay`` is not the delay the policy runs with, else None."""
    trained = config.trained_delay
    if trained is None:
        return None
    step = max(1.0 / timing.loop_hz, config.simulation_dt or 0.0)
    if abs(trained - timing.delay) < 0.5 * step - 1e-12:
        return None
    if timing.on_let:
        runs = (f"its action acts {timing.every} + 1 loop periods after the state it saw: "
                f"{_s(timing.delay)}")
    else:
        runs = "its action acts with no delay (the next iteration, as in a simulator's step)"
    if not timing.on_let and trained > 0:
        fix = ("give it a lane of its own (lane:=NAME, every:=N > 1: logical execution "
               "time, a delay of N + 1 loop periods)")
    elif trained > 0:
        fix = "retrain it for the delay it runs with"
    else:
        fix = "run it inline (no lane), as it was trained"
    near = timing.on_let and 0 < trained and abs(trained - timing.delay) < timing.period
    resolution = ("; a trainer whose physics step could not model it finer gives its "
                  "simulation_dt" if near and not config.simulation_dt else "")
    return (f"policy configuration {config.path}: trained_delay is {_s(trained)}, but the "
            f"policy runs {timing.describe()}, where {runs}; {fix}, or, if training "
            f"modelled {_s(timing.delay)}, say so in the YAML (trained_delay: "
            f"{timing.delay:g}){resolution}; ~on_delay_mismatch:=warn runs it anyway "
            "(docs/policies.md#the-delay-what-training-must-model)")


def _s(seconds: float) -> str:
    return f"{seconds:g} s"
