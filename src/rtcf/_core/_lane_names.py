"""Lane names: the ``lane`` a launcher names, and the runner's main lane."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from ._errors import ConfigurationError

MAIN_LANE = "main"  # the runner's own lane: components whose launcher names none

_LANE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def validate_lane_name(name: str) -> str | None:
    """What is wrong with a lane name, or None."""
    if not isinstance(name, str) or not _LANE.fullmatch(name):
        return (
            f"{name!r} is not a valid lane name; use letters, digits and _ "
            "(not starting with a digit)"
        )
    return None


def lane_from_params(params: Mapping[str, Any], component: str) -> str:
    """A launcher's ``lane`` parameter ("" when it gives none: the main lane)."""
    value = params.get("lane")
    if value is None or value == "":
        return ""
    problem = validate_lane_name(value)
    if problem:
        raise ConfigurationError(f"component {component!r}: lane {problem}")
    return str(value)
