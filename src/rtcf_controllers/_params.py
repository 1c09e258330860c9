"""A controller's parameters, named as ros2_controllers' YAML files name them.

ros2_controllers declare their parameters with generate_parameter_library: dotted
names (``constraints.goal_time``, ``gains.joint1.p``) with defaults and types. A
``ros__parameters`` section read by a launch file lands in rtcf's parameter tree as
nested names (``~constraints/goal_time``); a YAML key written with dots
(``"constraints.goal_time": 1.0``) lands as one leaf. Both are found here, so a
team's file configures the controller unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import rtcf

_MISSING: Any = object()


class ControllerParameters:
    """Typed access to one controller's ``ros__parameters`` (read in ``configure``)."""

    def __init__(self, component: rtcf.Component) -> None:
        self._component = component

    def _raw(self, name: str) -> Any:
        params = self._component.params
        for candidate in (name.replace(".", "/"), name):
            if params.has("~" + candidate):
                return params.get("~" + candidate)
        return _MISSING

    def error(self, name: str, value: Any, expected: str) -> rtcf.ConfigurationError:
        """The error that names the component, ``name``, its ``value`` and what to give."""
        return rtcf.ConfigurationError(
            f"component {self._component.full_name!r}: parameter {name!r} is {value!r}; "
            f"give {expected} (as the ros2_controllers YAML file would)"
        )

    def has(self, name: str) -> bool:
        """Whether the launch file or YAML file set ``name``."""
        return self._raw(name) is not _MISSING

    def _value(self, name: str, default: Any, expected: str) -> Any:
        """What the file set for ``name``, else ``default`` (checked as a value would
        be); without either, the error that asks for ``expected``."""
        value = self._raw(name)
        if value is _MISSING:
            if default is _MISSING:
                raise self.error(name, None, expected)
            return default
        return value

    def number(
        self, name: str, default: float = _MISSING, *, positive: bool = False, nan: bool = False
    ) -> float:
        """A double parameter (an int is taken as ros2's YAML loader would not, but
        people write ``1`` for ``1.0``). ``positive``: > 0; ``nan``: NaN allowed
        (ros2_controllers' "unlimited")."""
        value = self._value(name, default, "a number")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(name, value, "a number")
        number = float(value)
        if math.isnan(number) and not nan:
            raise self.error(name, value, "a number (not NaN)")
        if positive and not number > 0.0:
            raise self.error(name, value, "a number greater than 0")
        return number

    def integer(self, name: str, default: int = _MISSING) -> int:
        value = self._value(name, default, "an integer")
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(name, value, "an integer")
        return value

    def flag(self, name: str, default: bool = _MISSING) -> bool:
        value = self._value(name, default, "true or false")
        if not isinstance(value, bool):
            raise self.error(name, value, "true or false")
        return value

    def text(self, name: str, default: str = _MISSING, *, choices: Sequence[str] = ()) -> str:
        value = self._value(name, default, "a string")
        if not isinstance(value, str):
            raise self.error(name, value, "a string")
        if choices and value not in choices:
            raise self.error(name, value, "one of " + ", ".join(repr(c) for c in choices))
        return value

    def names(
        self, name: str, default: Sequence[str] = _MISSING, *, non_empty: bool = False
    ) -> list[str]:
        """A string array (joint names, interfaces): no duplicates."""
        value = self._value(name, default, "a list of strings")
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise self.error(name, value, "a list of strings")
        if non_empty and not value:
            raise self.error(name, value, "a list of at least one name")
        if len(set(value)) != len(value):
            raise self.error(name, value, "a list without duplicates")
        return list(value)

    def numbers(self, name: str, default: Sequence[float] = _MISSING) -> list[float]:
        """A double array (covariance diagonals)."""
        value = self._value(name, default, "a list of numbers")
        if not isinstance(value, (list, tuple)) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        ):
            raise self.error(name, value, "a list of numbers")
        return [float(v) for v in value]
