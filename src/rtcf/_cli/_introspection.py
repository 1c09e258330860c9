"""The original's introspection scripts as text: what a running runner holds.

``rtcf component_list``, ``component_info NAME``, ``connection_list``,
``connection_info TOPIC`` and ``component_order`` ask a running runner (through
its middleware: ``~/introspect``) and print with the functions here. The data is
:meth:`rtcf.Runner.introspect`'s, as the supervisor keeps it (current tunable
values and log levels included).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .._core._errors import RtcfError
from .._core._log import LogLevel

COMMANDS = ("component_list", "component_info", "connection_list", "connection_info",
            "component_order")


def render(command: str, data: dict[str, Any], name: str | None = None) -> str:
    """The text of one introspection command."""
    if command == "component_list":
        rows = [(c["name"], c["type"]) for c in data["components"]]
        return _table(rows) or "(no component is loaded)"
    if command == "component_order":
        if data.get("problem"):
            raise RtcfError(f"runner {data['runner']}: no order: {data['problem']}")
        return "\n".join(f"{i}. {n}" for i, n in enumerate(data["order"], 1)) or "(empty)"
    if command == "connection_list":
        topics = [
            (c["topic"], c["type"], "ROS" if c["ros"] else "") for c in data["connections"]
        ]
        return _table(topics) or "(no connection)"
    if command == "component_info":
        return _component_info(data, _required(command, name))
    if command == "connection_info":
        return _connection_info(data, _required(command, name))
    raise RtcfError(f"unknown introspection command {command!r}; use one of {', '.join(COMMANDS)}")


def mapping(data: dict[str, Any], whitelist: str) -> str:
    """What a run maps to the middleware, in one line: the topics it publishes (every
    mapped output) and subscribes (mapped inputs that nothing inside produces)."""
    published = [c for c in data["connections"] if c["ros"] and c["publishers"]]
    subscribed = [
        c for c in data["connections"] if c["ros"] and c["subscribers"] and not c["publishers"]
    ]
    served = [a for a in data.get("actions", []) if a["ros"]]
    if not published and not subscribed and not served:
        why = (
            "ros_mapping_whitelist is empty" if not whitelist
            else f"no topic matches ros_mapping_whitelist {whitelist!r} and not the blacklist"
        )
        return f"no port is mapped to a topic ({why})"

    def topics(conns: list[dict[str, Any]]) -> str:
        return ", ".join(f"{c['topic']} ({c['type'].removeprefix('builtins.')})" for c in conns)

    parts = []
    if published:
        parts.append("publishes " + topics(published))
    if subscribed:
        parts.append("subscribes " + topics(subscribed))
    if served:
        parts.append("serves actions " + ", ".join(f"{a['name']} ({a['type']})" for a in served))
    return "; ".join(parts)


def _required(command: str, name: str | None) -> str:
    if not name:
        what = "a component name" if command == "component_info" else "a topic"
        raise RtcfError(f"{command} needs {what}")
    return name


def _absolute(name: str) -> str:
    return name if name.startswith("/") else "/" + name


def _entry(
    data: dict[str, Any], table: str, key: str, name: str, what: str, listed: str
) -> Any:
    """The entry of ``data[table]`` whose ``key`` is ``name`` (made absolute); else an
    RtcfError that says ``what`` was asked for and lists the ``listed`` there are."""
    full = _absolute(name)
    by_key = {c[key]: c for c in data[table]}
    if full not in by_key:
        known = ", ".join(by_key) or "none"
        raise RtcfError(f"runner {data['runner']}: no {what} {full!r} ({listed}: {known})")
    return by_key[full]


def _component_info(data: dict[str, Any], name: str) -> str:
    c = _entry(data, "components", "name", name, "component", "loaded")
    lines = [f"{c['name']}  ({c['type']})"]
    if c.get("launcher"):
        lines.append(f"  launched by: {c['launcher']}")
    for kind in ("inputs", "outputs"):
        lines.append(f"  {kind}:")
        lines += [
            f"    {p['name']} -> {p['topic']}  [{p['type']}]" + _deadline(data, c, p)
            for p in c[kind]
        ] or ["    (none)"]
    if c.get("parameters"):
        lines.append("  parameters (read at configure):")
        lines += [f"    {k}: {v!r}" for k, v in sorted(c["parameters"].items())]
    if c.get("tunables"):
        lines.append("  tunable parameters:")
        for t in c["tunables"]:
            bounds = ""
            if t.get("min") is not None or t.get("max") is not None:
                lo = "" if t.get("min") is None else t["min"]
                hi = "" if t.get("max") is None else t["max"]
                bounds = f", {lo}..{hi}"
            if t.get("choices"):
                bounds = ", one of " + "|".join(str(x) for x in t["choices"])
            text = f"    {t['name']} = {t['value']!r}  ({t['type']}{bounds})"
            lines.append(text + (f"  {t['description']}" if t.get("description") else ""))
    level = c.get("log_level")
    if level is not None:
        try:
            lines.append(f"  log level: {LogLevel(int(level)).name.lower()}")
        except ValueError:
            lines.append(f"  log level: {level}")
    return "\n".join(lines)


def _deadline(data: dict[str, Any], component: dict[str, Any], port: dict[str, Any]) -> str:
    """An input's deadline, and whether it is past it now."""
    if port.get("deadline") is None:
        return ""
    past = f"{component['name']}.{port['name']}" in data.get("past_deadline", ())
    return f"  deadline {port['deadline']:g} s" + ("  PAST ITS DEADLINE NOW" if past else "")


def _connection_info(data: dict[str, Any], topic: str) -> str:
    c = _entry(data, "connections", "topic", topic, "connection", "topics")
    return "\n".join([
        f"{c['topic']}  [{c['type']}]",
        "  publishers: " + (", ".join(c["publishers"]) or "(none in the runner)"),
        "  subscribers: " + (", ".join(c["subscribers"]) or "(none in the runner)"),
        "  mapped to ROS: " + ("yes" if c["ros"] else "no"),
    ])


def _table(rows: Sequence[tuple[str, ...]]) -> str:
    if not rows:
        return ""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in rows
    )
