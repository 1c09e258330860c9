"""Finding a launch file from what a user types: ``FILE`` or ``PACKAGE FILE``, and args.

``rtcf launch``, ``rtcf graph``, ``rtcf check`` and :mod:`rtcf.testing` take the same
words: a path, or a package (found like ``$(find)`` and ``ros2 launch`` find it) and a
file name inside it, followed by any number of ``name:=value`` launch arguments.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from .._core._errors import LaunchError
from ._deployment import Deployment, plan
from ._substitutions import find_package
from ._xml import parse_launch_file


def split_target(words: Sequence[str]) -> tuple[str, dict[str, str]]:
    """Return the launch file path and the name:=value args from the positional words."""
    args: dict[str, str] = {}
    rest: list[str] = []
    for word in words:
        if ":=" in word:
            key, _, value = word.partition(":=")
            if not key:
                raise LaunchError(f"argument {word!r} has no name; write name:=value")
            args[key] = value
        else:
            rest.append(word)
    if len(rest) == 1:
        path = rest[0]
        if not os.path.exists(path):
            raise LaunchError(f"launch file {path!r} does not exist")
        return path, args
    if len(rest) == 2:
        package, name = rest
        root = Path(find_package(package))
        candidates = sorted(p for p in root.rglob(name) if p.is_file())
        if not candidates:
            raise LaunchError(f"package {package!r} ({root}) has no launch file {name!r}")
        return str(candidates[0]), args
    raise LaunchError(
        "give one launch file (FILE, or PACKAGE FILE) and any number of name:=value arguments"
    )


def load_deployment(words: Sequence[str]) -> Deployment:
    """Read and plan the launch file that ``words`` name."""
    path, args = split_target(words)
    return plan(parse_launch_file(path, args))
