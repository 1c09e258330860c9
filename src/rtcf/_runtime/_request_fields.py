"""The fields of a request to a runner (load, unload, tune, lifecycle), type-checked.

A runner serves anyone on its ROS domain or master (docs/ros2.md). Every field of a
request is checked here, before anything is imported or created, against what it must
be; a refusal is one line that names the service, the field, what it got and what it
wants, e.g. ``load_component: field 'remaps' got 7 (int); it wants a list of
'from:=to' strings``. Shared by the ROS 1 and the ROS 2 rt_runner.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any

from .._core._errors import RtcfError

MAX_NAME = 255  # characters of a node or component name (what DDS takes, with room)
_MODULE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_CLASS = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")
_NAME = re.compile(r"/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")
_NAMESPACE = re.compile(r"/|(/?[A-Za-z_][A-Za-z0-9_]*)+/?")
_SCALARS = (bool, int, float, str)


class RequestRefused(RtcfError):
    """A request whose fields are not what its service takes."""


def _shown(value: Any) -> str:
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def _string(pattern: re.Pattern[str] | None, wants: str) -> Callable[[Any], str | None]:
    def check(value: Any) -> str | None:
        if not isinstance(value, str):
            return f"a string: {wants}"
        if len(value) > MAX_NAME and pattern is not None:
            return f"{wants} of at most {MAX_NAME} characters"
        if pattern is not None and value and not pattern.fullmatch(value):
            return wants
        return None

    return check


def _boolean(value: Any) -> str | None:
    return None if isinstance(value, bool) else "true or false (a boolean, not a string)"


def _integer(value: Any) -> str | None:
    ok = isinstance(value, int) and not isinstance(value, bool)
    return None if ok else "an integer"


def _remaps(value: Any) -> str | None:
    wants = "a list of 'from:=to' strings"
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        return wants
    for rule in value:
        src, sep, dst = rule.partition(":=")
        if rule and (not sep or not src or not dst):
            return f"{wants} ({rule!r} is not one)"
    return None


def _regex(value: Any) -> str | None:
    if not isinstance(value, str):
        return "a string (a regular expression)"
    try:
        re.compile(value)
    except re.error as exc:
        return f"a regular expression ({exc})"
    return None


def _parameter(value: Any) -> str | None:
    if isinstance(value, _SCALARS):
        return None
    if isinstance(value, (list, tuple)) and all(isinstance(v, _SCALARS) for v in value):
        return None
    return "a bool, int, float or string, or a list of them"


_NAME_CHECK = _string(_NAME, "a name of letters, digits and _ (segments split by /)")
FIELDS: dict[str, dict[str, Callable[[Any], str | None]]] = {
    "load_component": {
        "module": _string(_MODULE, "a Python module name (pkg.module)"),
        "class": _string(_CLASS, "a class name"),
        "name": _NAME_CHECK,
        "namespace": _string(_NAMESPACE, "a namespace (/ or /a/b)"),
        "remaps": _remaps,
        "is_first": _boolean,
        "autostart": _boolean,
        "topics_ignore_for_graph": _regex,
        "launcher": _string(_NAME, "the launcher's node name"),
        "log_level": _integer,
    },
    "unload_component": {"name": _NAME_CHECK},
    "tune_component": {"name": _NAME_CHECK, "log_level": _integer},
    "lifecycle_component": {
        "name": _NAME_CHECK,
        "transition": lambda v: None if isinstance(v, (str, int)) and not isinstance(v, bool)
        else "a transition's label or id",
    },
}
REQUIRED = {
    "load_component": ("module", "class", "name"),
    "unload_component": ("name",),
    "tune_component": ("name",),
    "lifecycle_component": ("name",),
}
# services whose requests carry a component's parameters as param.<name>
_PARAMETERS = ("load_component", "tune_component")


def check_request(
    service: str, values: Mapping[str, Any], named: Mapping[str, str] | None = None
) -> dict[str, Any]:
    """``values`` if every field is what ``service`` takes; else RequestRefused.
    ``named``: the middleware's names of the fields, for the refusal (ROS 1's
    LoadComponent calls module and class ``package`` and ``type``)."""
    fields = FIELDS[service]
    try:
        _check(service, fields, values)
    except RequestRefused as exc:
        if not named:
            raise
        text = str(exc)
        for ours, theirs in named.items():
            text = text.replace(f"'{ours}'", f"'{theirs}'").replace(
                f"field(s) {ours}", f"field(s) {theirs}")
        raise RequestRefused(text) from None
    return dict(values)


def _check(service: str, fields: Mapping[str, Callable[[Any], str | None]],
           values: Mapping[str, Any]) -> None:
    for key, value in values.items():
        if not isinstance(key, str):
            raise RequestRefused(f"{service}: a field named {_shown(key)}; names are strings")
        if key.startswith("param.") and service in _PARAMETERS:
            wants = _parameter(value) if len(key) > len("param.") else "a parameter's name"
        elif key in fields:
            wants = fields[key](value)
        else:
            known = ", ".join(sorted(fields)) + (
                ", param.<name>" if service in _PARAMETERS else "")
            raise RequestRefused(f"{service}: unknown field {key[:60]!r}; it takes {known}")
        if wants is not None:
            raise RequestRefused(f"{service}: field {key[:60]!r} got {_shown(value)}; it "
                                 f"wants {wants}")
    missing = [k for k in REQUIRED[service] if values.get(k) in (None, "")]
    if missing:
        raise RequestRefused(f"{service}: missing field(s) {', '.join(missing)}")
