"""Components at several rates in one loop: dividers, phases and the plan they make.

A component runs every iteration unless its launcher says otherwise: ``rate`` (Hz,
dividing the runner's frequency exactly; ros2_control's ``update_rate`` parameter of a
controller says the same, 0 meaning the loop's) or ``every`` (a divider), and optionally
``phase`` (the iteration, modulo ``every``, it runs in). In an iteration where a slow
component runs, it runs at its place in the data-flow order; in the others it is
skipped and its outputs keep their last value (``OLD_DATA`` for readers; a port says
which iteration its value was written in). Without a ``phase``, the runner spreads
slow components over the phases, most expensive first (``cost_us``, a launcher
parameter, or measured: ``rtcf launch --costs timing.json``; 1 by default), so that
their runs fall in different iterations.
The schedule repeats every hyperperiod (the lcm of the dividers); the executor holds
one precomputed plan per phase and picks it with one index per iteration.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ._errors import ConfigurationError


@dataclass(frozen=True)
class Rate:
    """How often one component runs: ``rate`` Hz or every ``every`` iterations."""

    rate: float = 0.0  # Hz; 0: not given
    every: int = 0  # divider; 0: not given
    phase: int | None = None  # None: the runner chooses
    cost_us: float | None = None  # what one run costs, for spreading the load (None: 1)
    # the parameter that gave ``rate`` (for errors): rate, or a controller's update_rate
    source: str = field(default="rate", compare=False, repr=False)

    @property
    def cost(self) -> float:
        """The cost the runner spreads: ``cost_us``, or 1 when none was given."""
        return 1.0 if self.cost_us is None else self.cost_us

    @classmethod
    def from_params(cls, params: Mapping[str, Any], component: str) -> Rate:
        """From a launcher's parameters ``rate``, ``every``, ``phase``, ``cost_us``."""

        def number(key: str, kind: type) -> Any:
            value = params.get(key)
            if value is None:
                return None
            try:
                if isinstance(value, bool):
                    raise ValueError(value)
                converted = kind(value)
                if kind is int and float(value) != converted:
                    raise ValueError(value)
                return converted
            except (TypeError, ValueError):
                raise ConfigurationError(
                    f"component {component!r}: {key} is {value!r}, which is not "
                    + ("a whole number" if kind is int else "a number")
                ) from None

        rate = number("rate", float)
        every = number("every", int)
        phase = number("phase", int)
        cost = number("cost_us", float)
        source = "rate"
        update_rate = number("update_rate", float)  # ros2_control's name; 0: the loop's
        if update_rate is not None and update_rate < 0:
            raise ConfigurationError(
                f"component {component!r}: update_rate {update_rate:g} Hz must not be "
                "negative (0: the loop's rate)"
            )
        if update_rate:
            if rate is not None and rate != update_rate:
                raise ConfigurationError(
                    f"component {component!r}: rate {rate:g} Hz and update_rate "
                    f"{update_rate:g} Hz differ; give one of them (update_rate is "
                    "ros2_control's name of rate)"
                )
            if rate is None:
                rate, source = update_rate, "update_rate"
        if rate is not None and every is not None:
            raise ConfigurationError(
                f"component {component!r}: give {source} or every, not both"
            )
        if rate is not None and not rate > 0:
            raise ConfigurationError(f"component {component!r}: rate {rate:g} Hz must be above 0")
        if every is not None and every < 1:
            raise ConfigurationError(f"component {component!r}: every must be 1 or more")
        if phase is not None and phase < 0:
            raise ConfigurationError(f"component {component!r}: phase must not be negative")
        if cost is not None and cost < 0:
            raise ConfigurationError(f"component {component!r}: cost_us must not be negative")
        return cls(rate or 0.0, every or 0, phase, cost, source)

    def divider(self, frequency: float, component: str) -> tuple[int, int | None]:
        """``(every, phase)`` at the runner's ``frequency``; a clear error if ``rate``
        does not divide it or ``phase`` is not below ``every``."""
        every = self.every or 1
        if self.rate:
            k = frequency / self.rate
            every = round(k)
            if every < 1 or abs(k - every) > 1e-9 * k:
                below = max(1, math.floor(k))
                above = below + 1
                nearest = " or ".join(
                    f"{frequency / n:g} Hz (every:={n})" for n in sorted({below, above})
                )
                raise ConfigurationError(
                    f"component {component!r}: {self.source} {self.rate:g} Hz does not divide the "
                    f"runner's frequency {frequency:g} Hz; the nearest rates that do are "
                    f"{nearest}"
                )
        if self.phase is not None and self.phase >= every:
            raise ConfigurationError(
                f"component {component!r}: phase {self.phase} must be below every={every} "
                "(it is the iteration, modulo every, the component runs in)"
            )
        return every, self.phase


def spread(
    names: Sequence[str],
    dividers: Sequence[tuple[int, int | None]],
    costs: Sequence[float],
) -> list[tuple[int, int]]:
    """Phases for the components that have none: greedy, most expensive first.

    Each goes to the phase whose worst iteration (over the hyperperiod) would be the
    cheapest with it; ties go to the lowest phase. Deterministic: the same inputs
    give the same plan.
    """
    h = 1
    for every, _ in dividers:
        h = h * every // math.gcd(h, every)
    load = [0.0] * h
    result: list[tuple[int, int]] = [(every, phase or 0) for every, phase in dividers]
    fixed = [k for k, (every, phase) in enumerate(dividers) if phase is not None or every == 1]
    for k in fixed:
        every, phase = result[k]
        for i in range(phase, h, every):
            load[i] += costs[k]
    free = sorted(
        (k for k in range(len(dividers)) if k not in set(fixed)),
        key=lambda k: (-costs[k], names[k]),
    )
    for k in free:
        every = dividers[k][0]
        best = min(
            range(every), key=lambda f: (max(load[i] for i in range(f, h, every)), f)
        )
        result[k] = (every, best)
        for i in range(best, h, every):
            load[i] += costs[k]
    return result


def plan_table(
    names: Sequence[str],
    rates: Sequence[tuple[int, int]],
    costs: Sequence[float],
    frequency: float,
    lanes: Sequence[str] | None = None,
) -> list[str]:
    """The plan as text: one row per component, one column per phase of the
    hyperperiod (``x``: it runs in that iteration), then the cost of each phase
    (declared, or measured), grouped, the worst first.

    With ``lanes`` (each component's; "main" for the main lane) and some lane other
    than main, a lane column too; a phase then costs what its longest lock-step lane
    costs (lanes run side by side), and a lane on logical execution time (a lane
    other than main whose components run every N > 1) is left out of it.

    A name that starts with ``@`` is a step of the loop's own (``@let``: the LET
    lanes' handover in this process), not a component: it has no row."""
    keep = [k for k, n in enumerate(names) if not n.startswith("@")]
    names = [names[k] for k in keep]
    rates = [rates[k] for k in keep]
    costs = [costs[k] for k in keep]
    lanes = None if lanes is None else [lanes[k] for k in keep]
    h = 1
    for every, _ in rates:
        h = h * every // math.gcd(h, every)
    runs = [[(p - phase) % every == 0 for p in range(h)] for every, phase in rates]
    lane_of = list(lanes) if lanes is not None and any(n != "main" for n in lanes) else None
    if lane_of is None:
        cost = [
            sum(c for c, r in zip(costs, col, strict=True) if r) for col in zip(*runs, strict=True)
        ]
    else:
        cost = []
        for p in range(h):
            per_lane: dict[str, float] = {}
            for lane, (every, _), c, row in zip(lane_of, rates, costs, runs, strict=True):
                if row[p] and (lane == "main" or every == 1):
                    per_lane[lane] = per_lane.get(lane, 0.0) + c
            cost.append(max(per_lane.values(), default=0.0))
    width = max(len(n) for n in names)
    lines = [
        f"rates: the schedule repeats every {h} iterations ({h / frequency * 1e3:g} ms); "
        "x: the component runs in that phase (iteration mod {h})".replace("{h}", str(h))
    ]
    block = 50
    for start in range(0, h, block):
        stop = min(h, start + block)
        ticks = "".join(str(p // 10 % 10) if p % 10 == 0 else " " for p in range(start, stop))
        units = "".join(str(p % 10) for p in range(start, stop))
        lines.append(f"  {'phase':<{width}}  {ticks}".rstrip())
        header = "  every  phase  cost_us" if start == 0 else ""
        if header and lane_of is not None:
            header += "  lane"
        lines.append(f"  {'':<{width}}  {units}{header}")
        for k, (n, (every, phase), c, row) in enumerate(
            zip(names, rates, costs, runs, strict=True)
        ):
            cells = "".join("x" if r else "." for r in row[start:stop])
            extra = f"  {every:>5}  {phase:>5}  {c:>7.4g}" if start == 0 else ""
            if extra and lane_of is not None:
                lane = lane_of[k]
                let = lane != "main" and every > 1
                extra += f"  {lane}" + (" (LET)" if let else "")
            lines.append(f"  {n:<{width}}  {cells}{extra}")
    groups: dict[float, list[int]] = {}
    for p, c in enumerate(cost):
        groups.setdefault(c, []).append(p)
    parts = []
    for c in sorted(groups, reverse=True):
        phases = groups[c]
        shown = ", ".join(map(str, phases[:4])) + (", ..." if len(phases) > 4 else "")
        parts.append(f"{c:.4g} in {len(phases)} phase{'s' if len(phases) > 1 else ''} ({shown})")
    what = "cost_us" if lane_of is None else "cost_us; its longest lane, LET lanes apart"
    lines.append(f"  cost per iteration [us] ({what}), worst first: " + "; ".join(parts))
    return lines
