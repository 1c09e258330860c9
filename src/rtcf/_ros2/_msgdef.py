"""ROS 2 message definitions as MCAP's ``ros2msg`` schema wants them.

The text of ``pkg/msg/Type.msg`` followed by that of every message type it uses,
each after a line of 80 ``=`` and ``MSG: pkg/Type`` (the form rosbag2 writes). The
``.msg`` files come from ``share/<pkg>/msg/`` of each prefix on AMENT_PREFIX_PATH and
of this Python's prefix (where the ROS 2 wheels from PyPI put them).
"""

from __future__ import annotations

import os
import re
import sys
from functools import cache
from pathlib import Path

from .._core._errors import ConfigurationError

PRIMITIVE = {
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
}
_SEPARATOR = "=" * 80


def _prefixes() -> list[Path]:
    paths = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return [Path(p) for p in paths] + [Path(sys.prefix)]


def _msg_file(package: str, name: str) -> Path:
    for prefix in _prefixes():
        path = prefix / "share" / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path
    raise ConfigurationError(
        f"no definition of {package}/msg/{name}: share/{package}/msg/{name}.msg is in none "
        f"of {', '.join(map(str, _prefixes()))} (is the package installed, and its prefix "
        "on AMENT_PREFIX_PATH?)"
    )


def _dependencies(package: str, text: str) -> list[tuple[str, str]]:
    """(package, Type) of every message type the fields of ``text`` use, in order."""
    found = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        if len(words) < 2 or "=" in words[1] or (len(words) > 2 and words[2].startswith("=")):
            continue  # a constant (TYPE NAME=VALUE)
        base = re.sub(r"\[.*\]$", "", words[0])
        base = re.sub(r"<=\d+$", "", base)
        if base in PRIMITIVE:
            continue
        if base == "Header":
            found.append(("std_msgs", "Header"))
        elif "/" in base:
            parts = base.split("/")
            found.append((parts[0], parts[-1]))
        else:
            found.append((package, base))
    return found


@cache
def message_definition(type_name: str) -> str:
    """The schema text of ``pkg/msg/Type`` with every type it depends on."""
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] != "msg":
        raise ConfigurationError(f"{type_name!r} is not a ROS 2 message type (pkg/msg/Type)")
    package, name = parts[0], parts[2]
    text = _msg_file(package, name).read_text()
    out = [text.rstrip("\n")]
    seen = {(package, name)}
    queue = _dependencies(package, text)
    while queue:
        dep = queue.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        dep_text = _msg_file(*dep).read_text()
        out += [_SEPARATOR, f"MSG: {dep[0]}/{dep[1]}", dep_text.rstrip("\n")]
        queue += _dependencies(dep[0], dep_text)
    return "\n".join(out) + "\n"
