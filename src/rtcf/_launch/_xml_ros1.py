"""roslaunch's own elements and attributes, as the launch XML reader reads them.

ROS 1 launch files set parameters with ``<rosparam>`` (load, delete or dump; at the
top or inside a ``<node>``), remap and set the environment with ``<remap>`` and
``<env>`` at any level, and may give a ``<param>`` its value from a ``textfile=``.
``<machine>`` and ``<test>`` are ignored with a warning; ``command=`` and
``binfile=`` are refused. roslaunch's ``type="auto"`` inference also types the
untyped values of ROS 1 nodes and of parameters outside a node. The walk and the
elements both dialects share are in :mod:`._xml`.
"""

from __future__ import annotations

from typing import Any

from ._description import NodeDescription
from ._xml_reading import Element, Handler, Reader, Scope


def infer_ros1(value: str) -> Any:
    """roslaunch's ``type="auto"``: bool, int, float, else the string itself."""
    lowered = value.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    for convert in (int, float):
        try:
            return convert(value)
        except ValueError:
            pass
    return value


def _rel_join(first: str, second: str) -> str:
    if not first or second.startswith(("/", "~")):
        return second
    if not second:
        return first
    return first.rstrip("/") + "/" + second


class Ros1Tags:
    """The ROS 1 elements the reader dispatches to, and the ROS 1 parts of <param>."""

    def __init__(self, reader: Reader) -> None:
        self._reader = reader
        self.handlers: dict[str, Handler] = {
            "rosparam": self._rosparam_global,
            "remap": reader.remap,
            "env": reader.env,
            "machine": self._ignore,
            "test": self._ignore,
        }

    def param_text(self, name: str, element: Element, scope: Scope) -> str | None:
        """The text of a ``<param textfile=>`` (None without one); command= and binfile= refused."""
        for unsupported in ("command", "binfile"):
            if unsupported in element.attrs:
                raise self._reader.error(
                    f"<param name={name!r}>: {unsupported}= is not supported "
                    "(rtcf does not run shell commands or load binary files)",
                    element,
                    scope,
                )
        textfile = self._reader.attr(element, scope, "textfile")
        if textfile is not None:
            return self._reader.read_text(self._reader.path(textfile, scope), element, scope)
        return None

    def _rosparam_global(self, element: Element, scope: Scope) -> None:
        self.rosparam(element, scope, None)

    def rosparam(self, element: Element, scope: Scope, node: NodeDescription | None) -> None:
        command = self._reader.attr(element, scope, "command") or "load"
        target = _rel_join(
            self._reader.attr(element, scope, "ns") or "",
            self._reader.attr(element, scope, "param") or "",
        )
        base = node.full_name if node is not None else scope.namespace
        full = self._reader.param_name(target, element, scope, node) if target else base
        if command == "dump":
            self._reader.warn('<rosparam command="dump"> is ignored', element, scope)
        elif command == "delete":
            if not target:
                raise self._reader.error(
                    '<rosparam command="delete"> needs param= or ns=', element, scope
                )
            self._reader.description.parameters.delete(full)
        elif command == "load":
            self._rosparam_load(element, scope, full, bool(target))
        else:
            raise self._reader.error(
                f"<rosparam command={command!r}>: use load, delete or dump", element, scope
            )

    def _rosparam_load(self, element: Element, scope: Scope, full: str, named: bool) -> None:
        file = self._reader.attr(element, scope, "file")
        path = None if file is None else self._reader.path(file, scope)
        text = element.text if path is None else self._reader.read_text(path, element, scope)
        if self._reader.bool_attr(element, scope, "subst_value", False):
            text = self._reader.subst(text, element, scope)
        if not text.strip():
            raise self._reader.error("<rosparam> is empty; give YAML text or file=", element, scope)
        value = self._reader.parse_yaml(text, element, scope, file=path)
        if not named and not isinstance(value, dict):
            raise self._reader.error(
                "<rosparam> without param= must hold a YAML dictionary", element, scope
            )
        self._reader.set_tree(full, value)

    def _ignore(self, element: Element, scope: Scope) -> None:
        self._reader.warn(f"<{element.tag}> is ignored by rtcf", element, scope)
