"""``rtcf launch`` and ``ROSCONSOLE_CONFIG_FILE``: per-component start levels.

The file is the one the runner node's environment names: the launch file's
``<env>`` in the runner's scope (what roslaunch would give the rt_runner process),
else this process's environment. See :mod:`rtcf._launch._rosconsole`. With ROS 2 the
file is not read; ``--ros-args --log-level`` is ROS 2's way (docs/ros2.md).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping

from .._core._log import LogLevel, python_logger_name
from .._launch._deployment import RunnerDeployment
from .._launch._rosconsole import ENV, from_environment


def apply_rosconsole(
    target: RunnerDeployment,
    middleware: str,
    log_level: str,
    environ: Mapping[str, str] | None = None,
) -> list[str]:
    """Set each component's start level from the config file; return lines to print.

    Components the file says nothing about keep ``log_level`` (``--log-level``). A
    component set below it also gets its console logger lowered, so that its records
    show.
    """
    env = {**(os.environ if environ is None else environ), **target.env}
    if middleware == "ros2":
        if ENV in target.env:
            return [
                f"note: {ENV} (set by the launch file) is a ROS 1 setting and is not read "
                "with ROS 2; there, give a launcher --ros-args --log-level "
                "<logger>:=<level> (docs/ros2.md)"
            ]
        return []
    config = from_environment(env)
    if config is None:
        return []
    notes = [f"warning: {w}" for w in config.warnings]
    if not config.sources:
        return notes
    default = int(LogLevel[log_level.upper()])
    changed = []
    for spec in target.components:
        level = config.component_level(spec.full_name, default)
        spec.log_level = level
        if level < default:
            logging.getLogger(python_logger_name(spec.full_name)).setLevel(level)
        if level != default:
            changed.append(f"{spec.full_name} {LogLevel(level).name.lower()}")
    levels = ", ".join(changed) if changed else "none changed"
    notes.append(f"{ENV} {', '.join(config.sources)}: component log levels: {levels}")
    return notes
