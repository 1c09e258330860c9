"""Boolean parameters, parsed one way wherever they come from.

A launch file's ``value="false"``, a ROS 2 parameter (a bool), a ROS 1 parameter
server's ``0``: :func:`parse_bool` accepts ``true``/``false`` (any case, spaces
around), ``1``/``0`` as text or integer, and a bool. Anything else (``"no"``,
``"yes"``, ``2``, ``""``) is an error naming the parameter, never a guess.
"""

from __future__ import annotations

from typing import Any

from ._errors import ConfigurationError

_TRUE = ("true", "1")
_FALSE = ("false", "0")


def parse_bool(value: Any, name: str) -> bool:
    """``value`` as a boolean; a ConfigurationError naming parameter ``name`` if it is
    not one."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in _TRUE + _FALSE:
        return value.strip().lower() in _TRUE
    raise ConfigurationError(f"parameter {name!r} is {value!r}; use true or false")
