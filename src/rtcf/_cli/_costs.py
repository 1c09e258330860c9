"""Measured costs for spreading slow components: ``--costs timing.json``.

A run's timing.json gives each component's calculation time over the iterations in
which it ran. Its p99 becomes the ``cost_us`` of every component that declares none,
so that the runner spreads slow components by what they cost on this machine.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from .._core._errors import LaunchError
from .._launch._deployment import Deployment


def apply_measured_costs(deployment: Deployment, path: str) -> list[str]:
    """Set ``cost_us`` from ``path`` where the launch file declares none; say what."""
    where = f"--costs {path}"
    try:
        data = json.loads(Path(path).read_text())
    except OSError as exc:
        raise LaunchError(f"{where}: cannot read it: {exc.strerror}") from None
    except ValueError as exc:
        raise LaunchError(f"{where}: not JSON ({exc}); give a timing.json of --report") from None
    components = data.get("components") if isinstance(data, dict) else None
    if not isinstance(components, dict):
        raise LaunchError(
            f"{where}: no 'components' section; give the timing.json that "
            "rtcf launch --report DIR wrote (not under --sim, which measures nothing)"
        )
    used, missing = [], []
    for target in deployment.runners:
        for spec in target.components:
            if spec.rate.cost_us is not None:
                continue  # declared in the launch file: that rules
            stats = components.get(spec.full_name, {}).get("calc_us", {})
            p99 = stats.get("p99") if isinstance(stats, dict) else None
            if isinstance(p99, (int, float)) and p99 >= 0:
                spec.rate = replace(spec.rate, cost_us=float(p99))
                used.append(f"{spec.full_name} {p99:.3g}")
            else:
                missing.append(spec.full_name)
    notes = []
    if used:
        notes.append(f"costs from {path} (p99 of each run, us): " + ", ".join(used))
    if missing:
        notes.append(f"not measured in {path}, cost 1 us: " + ", ".join(missing))
    return notes
