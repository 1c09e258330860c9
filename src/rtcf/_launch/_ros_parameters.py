"""ROS 2 parameters files (``--params-file``, ``<param from=...>``), read in one place.

A file maps node keys to ``{ros__parameters: {...}}``; a key is a node's name, its full
name (with or without the leading '/'), or a pattern with ``*`` and ``**`` (``/**``:
every node), as rcl matches them. Both the launch reader (a node's ``<param
from=...>``) and the controller manager (its section, its controllers' sections, the
spawner's ``params_file``) read files through :func:`read_sections` or
:func:`sections_of`, so they accept and refuse the same files with the same words.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

from .._core._errors import ConfigurationError
from .._core._names import basename

ROS_PARAMETERS = "ros__parameters"


def params_key_matches(key: str, full_name: str) -> bool:
    """Whether a parameters file's node key ``key`` applies to node ``full_name``."""
    if key in (basename(full_name), full_name, full_name.lstrip("/")):
        return True
    if "*" not in key:
        return False
    parts = key.strip("/").split("/")
    regex = "".join(
        "(?:/[^/]+)*" if part == "**" else "/" + re.escape(part).replace(r"\*", "[^/]*")
        for part in parts
    )
    return re.fullmatch(regex, full_name) is not None


def flat(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{a: {b: 1}}`` -> ``{"a.b": 1}``: ROS 2's names for nested parameters."""
    out: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flat(value, name + "."))
        else:
            out[name] = value
    return out


def sections_of(data: Any, path: str) -> dict[str, dict[str, Any]]:
    """A parsed file's sections: node key -> its ``ros__parameters`` tree (nested, as
    written). Every entry is checked, as rcl checks the whole file: an error names
    ``path`` and the entry."""
    if not isinstance(data, dict):
        raise ConfigurationError(
            "a ROS 2 parameters file must map node names to {ros__parameters: {...}}",
            file=path)
    sections: dict[str, dict[str, Any]] = {}
    for key, entry in data.items():
        if not isinstance(entry, dict) or not isinstance(entry.get(ROS_PARAMETERS), dict):
            raise ConfigurationError(f"entry {key!r} has no {ROS_PARAMETERS!r} mapping",
                                     file=path)
        sections[str(key)] = entry[ROS_PARAMETERS]
    return sections


def read_sections(path: str) -> dict[str, dict[str, Any]]:
    """:func:`sections_of` the file at ``path``; one line naming it when it cannot be
    read or is not YAML."""
    try:
        with open(path, encoding="utf-8") as f:
            data = yaml.safe_load(f)
    except OSError as exc:
        raise ConfigurationError(f"cannot read the parameters file: {exc.strerror}",
                                 file=path) from None
    except yaml.YAMLError as exc:
        raise ConfigurationError(f"not valid YAML: {exc}".replace("\n", " "),
                                 file=path) from None
    return sections_of(data, path)


def params_for(sections: dict[str, dict[str, Any]], full_name: str) -> dict[str, Any]:
    """The flattened parameters of node ``full_name`` from one file's sections, the
    matching ones merged in the file's order (later keys winning, as rcl does)."""
    merged: dict[str, Any] = {}
    for key, tree in sections.items():
        if params_key_matches(key, full_name):
            merged.update(flat(tree))
    return merged
