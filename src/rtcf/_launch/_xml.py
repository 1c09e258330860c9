"""Reader for ROS 1 (roslaunch) and ROS 2 launch XML files.

One reader handles both dialects element by element, so a file may mix them. The
result is a :class:`~rtcf._launch._description.LaunchDescription`: the nodes with
their namespace, remaps, environment and location, and the parameter tree.

This module holds what the dialects share: the walk over the elements and the
elements both read alike (``<arg>``, ``<group>``, ``<include>``, ``<node>``,
``<param>``). Each dialect's own elements and attributes are in :mod:`._xml_ros1`
and :mod:`._xml_ros2`, which the walk dispatches to; what every element is read
with (the tree with its line numbers, scopes, substitutions, attribute values) is
in :mod:`._xml_reading`. Every error is a :class:`~rtcf._core._errors.LaunchError`
naming the file and the line.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .._core._errors import LaunchError, Location
from .._core._names import validate_name
from ._description import LaunchDescription, NodeDescription
from ._spawner import PACKAGE, node_name
from ._xml_reading import Config, Element, Handler, LaunchFile, Reader, Scope, parse_xml
from ._xml_ros1 import Ros1Tags, infer_ros1
from ._xml_ros2 import Ros2Tags, infer_ros2

__all__ = ["parse_launch_file", "parse_launch_string"]


def parse_launch_file(
    path: str | os.PathLike[str], args: Mapping[str, str] | None = None
) -> LaunchDescription:
    """Read the launch file at ``path``; ``args`` override the defaults of its ``<arg>``s."""
    source = os.fspath(path)
    try:
        data = Path(source).read_bytes()
    except FileNotFoundError:
        raise LaunchError("launch file not found", file=source) from None
    except OSError as exc:
        raise LaunchError(f"cannot read launch file: {exc.strerror}", file=source) from None
    return _Loader(source, args).load(data)


def parse_launch_string(
    text: str, source: str = "<string>", args: Mapping[str, str] | None = None
) -> LaunchDescription:
    """Read launch XML from ``text``; ``source`` names it in errors (and locates relative paths
    unless it is a pseudo-name like ``<string>``)."""
    return _Loader(source, args).load(text)


_PARAM_TYPES = ("str", "int", "double", "bool", "yaml", "auto")
_TYPE_ALIASES = {"string": "str", "boolean": "bool", "float": "double"}


class _Loader:
    """Reads one launch file and its includes into a LaunchDescription."""

    def __init__(self, source: str, args: Mapping[str, str] | None) -> None:
        self.source = source
        self.args = {str(k): str(v) for k, v in (args or {}).items()}
        self.description = LaunchDescription(source=source)
        self._reader = Reader(self.description)
        self._ros1 = Ros1Tags(self._reader)
        self._ros2 = Ros2Tags(self._reader)
        self._include_stack: list[str] = []
        self._node_locations: dict[str, Location] = {}
        # the elements both dialects share, then each dialect's own
        self._handlers: dict[str, Handler] = {
            "arg": self._arg,
            "group": self._group,
            "include": self._include,
            "node": self._node,
            "param": self._param_global,
            **self._ros1.handlers,
            **self._ros2.handlers,
        }

    # ----------------------------------------------------------------- entry

    def load(self, data: str | bytes) -> LaunchDescription:
        if self.source.startswith("<"):
            directory = os.getcwd()
        else:
            directory = os.path.dirname(os.path.abspath(self.source))
        file = LaunchFile(self.source, directory, dict(self.args), set(self.args))
        scope = Scope(file, configs={k: Config(v) for k, v in self.args.items()})
        self._load_file(data, scope, self._file_key(self.source))
        unknown = sorted(set(self.args) - set(file.declared))
        if unknown:
            names = ", ".join(repr(n) for n in unknown)
            raise LaunchError(
                f"arg {names} passed but not declared by this launch file "
                "(it has no <arg name=...> for it)",
                file=self.source,
            )
        self.description.args = {k: v for k, v in file.declared.items() if v is not None}
        return self.description

    def _file_key(self, path: str) -> str:
        return path if path.startswith("<") else os.path.realpath(path)

    def _load_file(self, data: str | bytes, scope: Scope, key: str) -> None:
        root = parse_xml(data, scope.file.path)
        if root.tag != "launch":
            raise self._reader.error(
                f"root element must be <launch>, not <{root.tag}>", root, scope
            )
        self._include_stack.append(key)
        try:
            self._run(root.children, scope)
        finally:
            self._include_stack.pop()

    def _run(self, elements: list[Element], scope: Scope) -> None:
        for element in elements:
            if not self._reader.active(element, scope):
                continue
            handler = self._handlers.get(element.tag)
            if handler is None:
                raise self._reader.error(
                    f"unknown element <{element.tag}> (not part of ROS 1 or ROS 2 launch XML, "
                    "or not supported by rtcf)",
                    element,
                    scope,
                )
            handler(element, scope)

    # ----------------------------------------------------------------- args

    def _arg(self, element: Element, scope: Scope) -> None:
        name = self._reader.required(element, scope, "name")
        if name in scope.declared:
            raise self._reader.error(
                f"arg {name!r} is declared twice (first at line {scope.declared[name]})",
                element,
                scope,
            )
        has_value = "value" in element.attrs
        has_default = "default" in element.attrs
        if has_value and has_default:
            raise self._reader.error(
                f"arg {name!r} has both value= (a constant) and default=; give only one",
                element,
                scope,
            )
        file = scope.file
        value: str | None
        if has_value:
            if name in file.explicit:
                raise self._reader.error(
                    f"arg {name!r} has a constant value= and cannot be overridden; "
                    "declare it with default= to allow passing it",
                    element,
                    scope,
                )
            value = self._reader.attr(element, scope, "value")
        elif name in file.passed:
            value = file.passed[name]
        else:
            value = self._reader.attr(element, scope, "default")
        scope.declared[name] = element.line
        scope.configs[name] = Config(value)
        file.declared[name] = value

    # ----------------------------------------------------------------- structure

    def _group(self, element: Element, scope: Scope) -> None:
        inner = scope.child() if self._reader.bool_attr(element, scope, "scoped", True) else scope
        inner.namespace = self._reader.namespace(
            self._reader.attr(element, scope, "ns"), inner.namespace, element, scope
        )
        self._run(element.children, inner)

    def _include(self, element: Element, scope: Scope) -> None:
        path = self._reader.path(self._reader.required(element, scope, "file"), scope)
        if path.endswith(".py"):
            raise self._reader.error(
                f"cannot include {path!r}: only XML launch files are supported", element, scope
            )
        if not os.path.isfile(path):
            raise self._reader.error(f"included file {path!r} not found", element, scope)
        key = self._file_key(path)
        if key in self._include_stack:
            raise self._reader.error(f"include cycle: {path!r} includes itself", element, scope)
        passed: dict[str, str] = {}
        if self._reader.bool_attr(element, scope, "pass_all_args", False):
            passed = {k: c.value for k, c in scope.configs.items() if c.value is not None}
        explicit, env = self._include_children(element, scope)
        passed.update(explicit)
        file = LaunchFile(path, os.path.dirname(os.path.abspath(path)), passed, set(explicit))
        configs = {k: Config(c.value, inherited=True) for k, c in scope.configs.items()}
        configs.update({k: Config(v) for k, v in passed.items()})
        namespace = self._reader.namespace(
            self._reader.attr(element, scope, "ns"), scope.namespace, element, scope
        )
        inner = Scope(file, namespace, configs, {}, list(scope.remaps), env)
        self._load_file(self._reader.read_bytes(path, element, scope), inner, key)
        for name in sorted(set(explicit) - set(file.declared)):
            self._reader.warn(
                f"arg {name!r} passed to {path!r}, which does not declare it", element, scope
            )

    def _include_children(
        self, element: Element, scope: Scope
    ) -> tuple[dict[str, str], dict[str, str]]:
        args: dict[str, str] = {}
        env = dict(scope.env)
        for child in self._reader.active_children(element, scope):
            if child.tag == "arg":
                name = self._reader.required(child, scope, "name")
                if "value" not in child.attrs:
                    raise self._reader.error(
                        f"<arg name={name!r}> inside <include> needs value=", child, scope
                    )
                args[name] = self._reader.required(child, scope, "value")
            elif child.tag == "env":
                env[self._reader.required(child, scope, "name")] = self._reader.required(
                    child, scope, "value"
                )
            else:
                raise self._reader.error(
                    f"<{child.tag}> is not allowed inside <include>", child, scope
                )
        return args, env

    # ----------------------------------------------------------------- nodes

    def _node(self, element: Element, scope: Scope) -> None:
        node = self._node_description(element, scope)
        for child in self._reader.active_children(element, scope):
            if child.tag == "remap":
                node.remaps.append(self._reader.remap_rule(child, scope))
            elif child.tag == "env":
                node.env[self._reader.required(child, scope, "name")] = self._reader.required(
                    child, scope, "value"
                )
            elif child.tag == "param":
                self._param(child, scope, node)
            elif child.tag == "rosparam":
                self._ros1.rosparam(child, scope, node)
            else:
                raise self._reader.error(
                    f"<{child.tag}> is not allowed inside <node>", child, scope
                )
        self.description.nodes.append(node)

    def _node_description(self, element: Element, scope: Scope) -> NodeDescription:
        package = self._reader.required(element, scope, "pkg")
        exec_ = self._reader.attr(element, scope, "exec")
        type_ = self._reader.attr(element, scope, "type")
        if (exec_ is None) == (type_ is None):
            raise self._reader.error(
                "<node> needs exactly one of exec= (ROS 2) or type= (ROS 1)", element, scope
            )
        executable = exec_ if exec_ is not None else type_
        assert executable is not None
        name = self._reader.attr(element, scope, "name")
        if name is None and package == PACKAGE:  # ros2_control's: as it names itself
            name = node_name(executable, self._node_args(element, scope))
        if name is None:
            name = executable
            self._reader.warn(
                f"<node> without name=; using the executable name {name!r}", element, scope
            )
        problem = validate_name(name, what="node name")
        if problem or "/" in name or name.startswith("~"):
            raise self._reader.error(
                problem or f"node name {name!r} must not contain a namespace", element, scope
            )
        if "ns" in element.attrs and "namespace" in element.attrs:
            raise self._reader.error(
                "<node> has both ns= and namespace=; give only one", element, scope
            )
        raw_ns = self._reader.attr(element, scope, "ns") or self._reader.attr(
            element, scope, "namespace"
        )
        node = NodeDescription(
            package=package,
            executable=executable,
            name=name,
            namespace=self._reader.namespace(raw_ns, scope.namespace, element, scope),
            location=Location(scope.file.path, element.line),
            dialect="ros2" if exec_ is not None else "ros1",
            args=self._node_args(element, scope),
            remaps=list(scope.remaps),
            env=dict(scope.env),
            output=self._reader.attr(element, scope, "output"),
            on_exit=self._on_exit(element, scope),
        )
        self._check_unique(node, element, scope)
        return node

    def _on_exit(self, element: Element, scope: Scope) -> str | None:
        """ROS 2's ``on_exit="shutdown"``, ROS 1's ``required="true"``: the node's exit ends
        the launch (other actions in ``on_exit`` are not read)."""
        if self._reader.bool_attr(element, scope, "required", False):
            return "shutdown"
        return "shutdown" if self._reader.attr(element, scope, "on_exit") == "shutdown" else None

    def _node_args(self, element: Element, scope: Scope) -> str:
        args = self._reader.attr(element, scope, "args") or ""
        ros_args = self._reader.attr(element, scope, "ros_args")
        if ros_args:
            args = f"{args} --ros-args {ros_args}".strip()
        return args

    def _check_unique(self, node: NodeDescription, element: Element, scope: Scope) -> None:
        first = self._node_locations.get(node.full_name)
        if first is not None:
            raise self._reader.error(
                f"node {node.full_name!r} is defined twice: {first} and {node.location}; "
                "give each node a unique name",
                element,
                scope,
            )
        self._node_locations[node.full_name] = node.location

    # ----------------------------------------------------------------- parameters

    def _param_global(self, element: Element, scope: Scope) -> None:
        self._param(element, scope, None)

    def _param(
        self, element: Element, scope: Scope, node: NodeDescription | None, prefix: str = ""
    ) -> None:
        if "from" in element.attrs:
            self._ros2.params_file(element, scope, node)
            return
        name = prefix + self._reader.required(element, scope, "name")
        children = self._reader.active_children(element, scope)
        if children:
            self._nested_params(element, children, scope, node, name)
            return
        value = self._param_value(name, element, scope, node)
        full = self._reader.param_name(name, element, scope, node)
        self._reader.set_tree(full, value)
        self.description.param_locations[full] = Location(scope.file.path, element.line)

    def _nested_params(
        self,
        element: Element,
        children: list[Element],
        scope: Scope,
        node: NodeDescription | None,
        name: str,
    ) -> None:
        if "value" in element.attrs:
            raise self._reader.error(
                f"<param name={name!r}> has both value= and nested <param>s", element, scope
            )
        for child in children:
            if child.tag != "param":
                raise self._reader.error(
                    f"<{child.tag}> is not allowed inside <param>", child, scope
                )
            if "from" in child.attrs:
                raise self._reader.error("nested <param> cannot have from=", child, scope)
            self._param(child, scope, node, prefix=name.rstrip("/") + "/")

    def _param_value(
        self, name: str, element: Element, scope: Scope, node: NodeDescription | None
    ) -> Any:
        text = self._ros1.param_text(name, element, scope)
        if text is not None:
            return text
        value = self._reader.attr(element, scope, "value")
        if value is None:
            raise self._reader.error(
                f"<param name={name!r}> needs value= (or textfile=, binfile=, command=)",
                element,
                scope,
            )
        ptype = self._reader.attr(element, scope, "type")
        separator = self._reader.attr(element, scope, "value-sep")
        if separator is not None:
            items = value.split(separator) if value else []
            return [self._typed(name, item, ptype, element, scope, node) for item in items]
        return self._typed(name, value, ptype, element, scope, node)

    def _typed(
        self,
        name: str,
        value: str,
        ptype: str | None,
        element: Element,
        scope: Scope,
        node: NodeDescription | None,
    ) -> Any:
        if ptype is None:
            ros2 = node is not None and node.dialect == "ros2"
            return infer_ros2(value) if ros2 else infer_ros1(value)
        kind = _TYPE_ALIASES.get(ptype.strip().lower(), ptype.strip().lower())
        if kind not in _PARAM_TYPES:
            raise self._reader.error(
                f"<param name={name!r}>: unknown type {ptype!r}; use one of "
                + ", ".join(_PARAM_TYPES),
                element,
                scope,
            )
        converters: dict[str, Callable[[str], Any]] = {
            "str": str,
            "int": lambda v: int(v.strip()),
            "double": lambda v: float(v.strip()),
            "bool": lambda v: self._reader.boolean(v, f"param {name!r} value", element, scope),
            "yaml": lambda v: self._reader.parse_yaml(v, element, scope),
            "auto": infer_ros1,
        }
        try:
            return converters[kind](value)
        except ValueError:
            raise self._reader.error(
                f"<param name={name!r}>: {value!r} is not a valid {kind}", element, scope
            ) from None
