"""What a runner's status line shows while its loop runs, and what ticks it.

:class:`LiveStatus` is the line (iterations, overruns, jitter, faults, who may change
the runner); the CLI prints it and the bridges publish it on /diagnostics.
"""

from __future__ import annotations

from dataclasses import dataclass

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
