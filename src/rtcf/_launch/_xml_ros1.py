"""roslaunch's own elements and attributes, as the launch XML reader reads them.

ROS 1 launch files set parameters with ``<rosparam>`` (load, delete or dump; at the
top or inside a ``<node>``), remap and set the environment with ``<remap>`` and
``<env>`` at any level, and may give a ``<param>`` its value from a ``textfile=`` (the
text), a ``binfile=`` (the bytes) or a ``command=`` (its standard output, as roslaunch
runs it: split with shlex, no shell, once while the file is read; :mod:`._commands`).
``<machine>`` and ``<test>`` are ignored with a warning. roslaunch's ``type="auto"``
inference also types the untyped values of ROS 1 nodes and of parameters outside a
node. The walk and the elements both dialects share are in :mod:`._xml`.
"""

from __future__ import annotations

from typing import Any

from . import _commands
from ._description import NodeDescription
from ._xml_reading import Element, Handler, Reader, Scope

_SOURCES = ("value", "textfile", "binfile", "command")


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

    def param_text(self, name: str, element: Element, scope: Scope) -> str | bytes | None:
        """The value of a ``<param>`` given by ``textfile=`` (text), ``binfile=`` (bytes) or
        ``command=`` (its stdout); None when it has ``value=``. One of the four, as in
        roslaunch."""
        given = [key for key in _SOURCES if key in element.attrs]
        if len(given) > 1:
            raise self._reader.error(
                f"<param name={name!r}> has {' and '.join(given)}=: give only one of value=, "
                "textfile=, binfile= or command=",
                element,
                scope,
            )
        textfile = self._reader.attr(element, scope, "textfile")
        if textfile is not None:
            return self._reader.read_text(self._reader.path(textfile, scope), element, scope)
        binfile = self._reader.attr(element, scope, "binfile")
        if binfile is not None:
            return self._reader.read_bytes(self._reader.path(binfile, scope), element, scope)
        command = self._reader.attr(element, scope, "command")
        if command is not None:
            return self._command(name, command, element, scope)
        return None

    def _command(self, name: str, command: str, element: Element, scope: Scope) -> str:
        """roslaunch's command parameter: the stdout of a command that exits with 0; what
        it writes to stderr (which roslaunch lets through to the terminal) is a warning."""
        shown = _commands.one_line(command)
        try:
            output = _commands.run(command, extra_env=scope.env)
        except _commands.CommandFailed as exc:
            raise self._reader.error(
                f"<param name={name!r}>: cannot load command parameter: command {shown!r} "
                f"failed: {exc}",
                element,
                scope,
            ) from None
        if output.stderr.strip():
            self._reader.warn(
                f"<param name={name!r}>: command {shown!r} wrote to stderr: "
                + _commands.first_lines(output.stderr),
                element,
                scope,
            )
        return output.stdout

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
