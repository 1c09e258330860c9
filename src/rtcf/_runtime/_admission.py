"""Who may make requests of a runner: its lock and its allowed modules.

A runner's lock (``settings.lock``) applies once its loop has run (a launch file's
components load before); its ``allowed_modules`` refuse a module before anything
imports it (docs/security.md).
"""

from __future__ import annotations

from .._core._settings import RunnerSettings


def access_of(settings: RunnerSettings, locked: bool | None = None) -> str:
    """Who may change a runner, in a line: its lock (and whether it applies yet) and
    its allowed modules; empty when it is open to any request."""
    parts = []
    if settings.lock != "none":
        when = "" if locked is None else (" (applies)" if locked else
                                          " (applies once the loop runs)")
        parts.append(f"lock {settings.lock}{when}")
    if settings.allowed_modules:
        parts.append("allowed modules " + " ".join(settings.allowed_modules))
    return "; ".join(parts)
