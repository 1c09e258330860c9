"""Reader for ROS 1 (roslaunch) and ROS 2 launch XML files.

One reader handles both dialects element by element, so a file may mix them. The
result is a :class:`~rtcf._launch._description.LaunchDescription`: the nodes with
their namespace, remaps, environment and location, and the parameter tree.

Every error is a :class:`~rtcf._core._errors.LaunchError` naming the file and the line.
ElementTree drops line numbers, so the XML is read with :mod:`xml.parsers.expat`
into small :class:`_Element` objects that keep the line of each start tag.
"""

from __future__ import annotations

import os
import random
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple
from xml.parsers import expat

import yaml

from .._core._errors import LaunchError, Location
from .._core._names import expand, join, normalize_namespace, validate_name
from ._description import LaunchDescription, NodeDescription
from ._substitutions import SubstitutionError, find_package, substitute

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


# --------------------------------------------------------------------------- XML tree


@dataclass
class _Element:
    tag: str
    attrs: dict[str, str]
    line: int
    children: list[_Element] = field(default_factory=list)
    text_parts: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        return "".join(self.text_parts)


def _parse_xml(data: str | bytes, file: str) -> _Element:
    parser = expat.ParserCreate()
    parser.buffer_text = True
    stack: list[_Element] = []
    roots: list[_Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = _Element(tag, attrs, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    def chars(text: str) -> None:
        if stack:
            stack[-1].text_parts.append(text)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code) if exc.code is not None else str(exc)
        raise LaunchError(f"malformed XML: {message}", file=file, line=exc.lineno) from None
    return roots[0]


# --------------------------------------------------------------------------- scopes


class _Config(NamedTuple):
    """An arg or launch configuration; ``inherited`` ones come from an including file."""

    value: str | None
    inherited: bool = False


@dataclass
class _File:
    """One launch file being read, with the args passed to it."""

    path: str  # as shown in messages
    directory: str  # absolute, for relative paths and $(dirname)
    passed: dict[str, str]
    explicit: set[str]  # passed by name (not by pass_all_args): constants may not be overridden
    declared: dict[str, str | None] = field(default_factory=dict)  # arg name -> final value


@dataclass
class _Scope:
    """What is in force at one point of a file: namespace, args, remaps, environment."""

    file: _File
    namespace: str = "/"
    configs: dict[str, _Config] = field(default_factory=dict)
    declared: dict[str, int] = field(default_factory=dict)  # arg name -> line, for duplicates
    remaps: list[tuple[str, str]] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)

    def child(self) -> _Scope:
        return _Scope(
            self.file,
            self.namespace,
            dict(self.configs),
            dict(self.declared),
            list(self.remaps),
            dict(self.env),
        )


class _Substitutions:
    """The substitution context of one scope (see ``_substitutions.SubstitutionContext``)."""

    def __init__(self, loader: _Loader, scope: _Scope) -> None:
        self._loader = loader
        self._scope = scope

    def arg(self, name: str, *, strict: bool) -> str:
        config = self._scope.configs.get(name)
        if config is None or (strict and config.inherited):
            raise SubstitutionError(
                f'arg {name!r} is not defined; declare it with <arg name="{name}" .../> '
                f"or pass {name}:=value"
            )
        if config.value is None:
            raise SubstitutionError(
                f"arg {name!r} is required but has no value; pass {name}:=value "
                "(or give the <arg> a default)"
            )
        return config.value

    def variables(self) -> dict[str, str]:
        return {k: c.value for k, c in self._scope.configs.items() if c.value is not None}

    def dirname(self) -> str:
        return self._scope.file.directory

    def anon(self, name: str) -> str:
        return self._loader.anon(name)

    def find_package(self, name: str) -> str:
        return self._loader.find_package(name)


def _push_namespace(current: str, ns: str | None) -> str:
    if not ns:
        return current
    return normalize_namespace(ns) if ns.startswith("/") else join(current, ns)


def _rel_join(first: str, second: str) -> str:
    if not first or second.startswith(("/", "~")):
        return second
    if not second:
        return first
    return first.rstrip("/") + "/" + second


# --------------------------------------------------------------------------- values

_TRUE = ("true", "1")
_FALSE = ("false", "0")
_PARAM_TYPES = ("str", "int", "double", "bool", "yaml", "auto")
_TYPE_ALIASES = {"string": "str", "boolean": "bool", "float": "double"}


def _infer_ros1(value: str) -> Any:
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


def _infer_ros2(value: str) -> Any:
    """ROS 2 launch: YAML-style inference limited to bool, int and float, and lists
    of one of them (ROS 2 parameters' arrays)."""
    lowered = value.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        loaded = yaml.safe_load(value)
    except yaml.YAMLError:
        return value
    if isinstance(loaded, (int, float)) and not isinstance(loaded, bool):
        return loaded
    if isinstance(loaded, list) and loaded and len({type(v) for v in loaded}) == 1:
        if isinstance(loaded[0], (bool, int, float, str)):  # value="[1.0, 2.0]": an array
            return loaded
    return value


def _params_file_key_matches(key: str, node: NodeDescription) -> bool:
    full = node.full_name
    if key in (node.name, full, full.lstrip("/")):
        return True
    if "*" not in key:
        return False
    parts = key.strip("/").split("/")
    regex = "".join(
        "(?:/[^/]+)*" if part == "**" else "/" + re.escape(part).replace(r"\*", "[^/]*")
        for part in parts
    )
    return re.fullmatch(regex, full) is not None


# --------------------------------------------------------------------------- loader

_Handler = Callable[["_Loader", _Element, _Scope], None]


class _Loader:
    """Reads one launch file and its includes into a LaunchDescription."""

    def __init__(self, source: str, args: Mapping[str, str] | None) -> None:
        self.source = source
        self.args = {str(k): str(v) for k, v in (args or {}).items()}
        self.description = LaunchDescription(source=source)
        self._anon: dict[str, str] = {}
        self._rng = random.Random()
        self._packages: dict[str, str] = {}
        self._include_stack: list[str] = []
        self._node_locations: dict[str, Location] = {}

    # ----------------------------------------------------------------- entry

    def load(self, data: str | bytes) -> LaunchDescription:
        if self.source.startswith("<"):
            directory = os.getcwd()
        else:
            directory = os.path.dirname(os.path.abspath(self.source))
        file = _File(self.source, directory, dict(self.args), set(self.args))
        scope = _Scope(file, configs={k: _Config(v) for k, v in self.args.items()})
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

    def _load_file(self, data: str | bytes, scope: _Scope, key: str) -> None:
        root = _parse_xml(data, scope.file.path)
        if root.tag != "launch":
            raise self._error(f"root element must be <launch>, not <{root.tag}>", root, scope)
        self._include_stack.append(key)
        try:
            self._run(root.children, scope)
        finally:
            self._include_stack.pop()

    def _run(self, elements: list[_Element], scope: _Scope) -> None:
        for element in elements:
            if not self._active(element, scope):
                continue
            handler = _LAUNCH_HANDLERS.get(element.tag)
            if handler is None:
                raise self._error(
                    f"unknown element <{element.tag}> (not part of ROS 1 or ROS 2 launch XML, "
                    "or not supported by rtcf)",
                    element,
                    scope,
                )
            handler(self, element, scope)

    # ----------------------------------------------------------------- helpers

    def anon(self, name: str) -> str:
        if name not in self._anon:
            self._anon[name] = f"{name}_{self._rng.getrandbits(48):012x}"
        return self._anon[name]

    def find_package(self, name: str) -> str:
        if name not in self._packages:
            self._packages[name] = find_package(name)
        return self._packages[name]

    def _error(self, message: str, element: _Element, scope: _Scope) -> LaunchError:
        return LaunchError(message, file=scope.file.path, line=element.line)

    def _warn(self, message: str, element: _Element, scope: _Scope) -> None:
        self.description.warnings.append(f"{scope.file.path}:{element.line}: {message}")

    def _subst(self, text: str, element: _Element, scope: _Scope) -> str:
        try:
            return substitute(text, _Substitutions(self, scope))
        except SubstitutionError as exc:
            raise self._error(str(exc), element, scope) from None

    def _attr(self, element: _Element, scope: _Scope, name: str) -> str | None:
        raw = element.attrs.get(name)
        return None if raw is None else self._subst(raw, element, scope)

    def _required(self, element: _Element, scope: _Scope, name: str) -> str:
        value = self._attr(element, scope, name)
        if value is None:
            raise self._error(f"<{element.tag}> needs attribute {name!r}", element, scope)
        return value

    def _bool(self, value: str, what: str, element: _Element, scope: _Scope) -> bool:
        lowered = value.strip().lower()
        if lowered in _TRUE:
            return True
        if lowered in _FALSE:
            return False
        raise self._error(
            f"{what}={value!r} is not a boolean; use true, false, 1 or 0", element, scope
        )

    def _bool_attr(self, element: _Element, scope: _Scope, name: str, default: bool) -> bool:
        value = self._attr(element, scope, name)
        return default if value is None else self._bool(value, name, element, scope)

    def _active(self, element: _Element, scope: _Scope) -> bool:
        if_value = self._attr(element, scope, "if")
        if if_value is not None and not self._bool(if_value, "if", element, scope):
            return False
        unless_value = self._attr(element, scope, "unless")
        return unless_value is None or not self._bool(unless_value, "unless", element, scope)

    def _active_children(self, element: _Element, scope: _Scope) -> list[_Element]:
        return [c for c in element.children if self._active(c, scope)]

    def _path(self, raw: str, scope: _Scope) -> str:
        path = os.path.expanduser(raw)
        if os.path.isabs(path):
            return os.path.normpath(path)
        return os.path.normpath(os.path.join(scope.file.directory, path))

    def _read_text(self, path: str, element: _Element, scope: _Scope) -> str:
        try:
            return Path(path).read_text(encoding="utf-8")
        except OSError as exc:
            raise self._error(f"cannot read {path!r}: {exc.strerror}", element, scope) from None

    def _yaml(self, text: str, element: _Element, scope: _Scope, file: str | None = None) -> Any:
        try:
            return yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            problem = getattr(exc, "problem", None) or str(exc)
            if file is not None:
                line = None if mark is None else mark.line + 1
                raise LaunchError(f"invalid YAML: {problem}", file=file, line=line) from None
            line = element.line + (0 if mark is None else mark.line)
            raise LaunchError(
                f"invalid YAML in <{element.tag}>: {problem}", file=scope.file.path, line=line
            ) from None

    def _namespace(self, raw: str | None, current: str, element: _Element, scope: _Scope) -> str:
        namespace = _push_namespace(current, raw)
        problem = validate_name(namespace, what="namespace")
        if problem:
            raise self._error(problem, element, scope)
        return namespace

    def _set_tree(self, name: str, value: Any) -> None:
        """Set ``value`` at ``name``, merging dicts leaf by leaf into what is there."""
        if isinstance(value, Mapping) and value:
            for key, sub in value.items():
                self._set_tree(f"{name.rstrip('/')}/{key}", sub)
        else:
            self.description.parameters.set(name, value)

    # ----------------------------------------------------------------- args

    def _arg(self, element: _Element, scope: _Scope) -> None:
        name = self._required(element, scope, "name")
        if name in scope.declared:
            raise self._error(
                f"arg {name!r} is declared twice (first at line {scope.declared[name]})",
                element,
                scope,
            )
        has_value = "value" in element.attrs
        has_default = "default" in element.attrs
        if has_value and has_default:
            raise self._error(
                f"arg {name!r} has both value= (a constant) and default=; give only one",
                element,
                scope,
            )
        file = scope.file
        value: str | None
        if has_value:
            if name in file.explicit:
                raise self._error(
                    f"arg {name!r} has a constant value= and cannot be overridden; "
                    "declare it with default= to allow passing it",
                    element,
                    scope,
                )
            value = self._attr(element, scope, "value")
        elif name in file.passed:
            value = file.passed[name]
        else:
            value = self._attr(element, scope, "default")
        scope.declared[name] = element.line
        scope.configs[name] = _Config(value)
        file.declared[name] = value

    def _let(self, element: _Element, scope: _Scope) -> None:
        name = self._required(element, scope, "name")
        scope.configs[name] = _Config(self._required(element, scope, "value"))

    # ----------------------------------------------------------------- structure

    def _group(self, element: _Element, scope: _Scope) -> None:
        inner = scope.child() if self._bool_attr(element, scope, "scoped", True) else scope
        inner.namespace = self._namespace(
            self._attr(element, scope, "ns"), inner.namespace, element, scope
        )
        self._run(element.children, inner)

    def _push_ros_namespace(self, element: _Element, scope: _Scope) -> None:
        raw = self._required(element, scope, "namespace")
        scope.namespace = self._namespace(raw, scope.namespace, element, scope)

    def _include(self, element: _Element, scope: _Scope) -> None:
        path = self._path(self._required(element, scope, "file"), scope)
        if path.endswith(".py"):
            raise self._error(
                f"cannot include {path!r}: only XML launch files are supported", element, scope
            )
        if not os.path.isfile(path):
            raise self._error(f"included file {path!r} not found", element, scope)
        key = self._file_key(path)
        if key in self._include_stack:
            raise self._error(f"include cycle: {path!r} includes itself", element, scope)
        passed: dict[str, str] = {}
        if self._bool_attr(element, scope, "pass_all_args", False):
            passed = {k: c.value for k, c in scope.configs.items() if c.value is not None}
        explicit, env = self._include_children(element, scope)
        passed.update(explicit)
        file = _File(path, os.path.dirname(os.path.abspath(path)), passed, set(explicit))
        configs = {k: _Config(c.value, inherited=True) for k, c in scope.configs.items()}
        configs.update({k: _Config(v) for k, v in passed.items()})
        namespace = self._namespace(
            self._attr(element, scope, "ns"), scope.namespace, element, scope
        )
        inner = _Scope(file, namespace, configs, {}, list(scope.remaps), env)
        self._load_file(self._read_bytes(path, element, scope), inner, key)
        for name in sorted(set(explicit) - set(file.declared)):
            self._warn(
                f"arg {name!r} passed to {path!r}, which does not declare it", element, scope
            )

    def _include_children(
        self, element: _Element, scope: _Scope
    ) -> tuple[dict[str, str], dict[str, str]]:
        args: dict[str, str] = {}
        env = dict(scope.env)
        for child in self._active_children(element, scope):
            if child.tag == "arg":
                name = self._required(child, scope, "name")
                if "value" not in child.attrs:
                    raise self._error(
                        f"<arg name={name!r}> inside <include> needs value=", child, scope
                    )
                args[name] = self._required(child, scope, "value")
            elif child.tag == "env":
                env[self._required(child, scope, "name")] = self._required(child, scope, "value")
            else:
                raise self._error(f"<{child.tag}> is not allowed inside <include>", child, scope)
        return args, env

    def _read_bytes(self, path: str, element: _Element, scope: _Scope) -> bytes:
        try:
            return Path(path).read_bytes()
        except OSError as exc:
            raise self._error(f"cannot read {path!r}: {exc.strerror}", element, scope) from None

    def _remap(self, element: _Element, scope: _Scope) -> None:
        scope.remaps.append(self._remap_rule(element, scope))

    def _remap_rule(self, element: _Element, scope: _Scope) -> tuple[str, str]:
        return self._required(element, scope, "from"), self._required(element, scope, "to")

    def _env(self, element: _Element, scope: _Scope) -> None:
        scope.env[self._required(element, scope, "name")] = self._required(element, scope, "value")

    def _ignore(self, element: _Element, scope: _Scope) -> None:
        self._warn(f"<{element.tag}> is ignored by rtcf", element, scope)

    def _not_supported(self, element: _Element, scope: _Scope) -> None:
        raise self._error(f"<{element.tag}> is not supported yet", element, scope)

    # ----------------------------------------------------------------- nodes

    def _node(self, element: _Element, scope: _Scope) -> None:
        node = self._node_description(element, scope)
        for child in self._active_children(element, scope):
            if child.tag == "remap":
                node.remaps.append(self._remap_rule(child, scope))
            elif child.tag == "env":
                node.env[self._required(child, scope, "name")] = self._required(
                    child, scope, "value"
                )
            elif child.tag == "param":
                self._param(child, scope, node)
            elif child.tag == "rosparam":
                self._rosparam(child, scope, node)
            else:
                raise self._error(f"<{child.tag}> is not allowed inside <node>", child, scope)
        self.description.nodes.append(node)

    def _node_description(self, element: _Element, scope: _Scope) -> NodeDescription:
        package = self._required(element, scope, "pkg")
        exec_ = self._attr(element, scope, "exec")
        type_ = self._attr(element, scope, "type")
        if (exec_ is None) == (type_ is None):
            raise self._error(
                "<node> needs exactly one of exec= (ROS 2) or type= (ROS 1)", element, scope
            )
        executable = exec_ if exec_ is not None else type_
        assert executable is not None
        name = self._attr(element, scope, "name")
        if name is None:
            name = executable
            self._warn(f"<node> without name=; using the executable name {name!r}", element, scope)
        problem = validate_name(name, what="node name")
        if problem or "/" in name or name.startswith("~"):
            raise self._error(
                problem or f"node name {name!r} must not contain a namespace", element, scope
            )
        if "ns" in element.attrs and "namespace" in element.attrs:
            raise self._error("<node> has both ns= and namespace=; give only one", element, scope)
        raw_ns = self._attr(element, scope, "ns") or self._attr(element, scope, "namespace")
        node = NodeDescription(
            package=package,
            executable=executable,
            name=name,
            namespace=self._namespace(raw_ns, scope.namespace, element, scope),
            location=Location(scope.file.path, element.line),
            dialect="ros2" if exec_ is not None else "ros1",
            args=self._node_args(element, scope),
            remaps=list(scope.remaps),
            env=dict(scope.env),
            output=self._attr(element, scope, "output"),
        )
        self._check_unique(node, element, scope)
        return node

    def _node_args(self, element: _Element, scope: _Scope) -> str:
        args = self._attr(element, scope, "args") or ""
        ros_args = self._attr(element, scope, "ros_args")
        if ros_args:
            args = f"{args} --ros-args {ros_args}".strip()
        return args

    def _check_unique(self, node: NodeDescription, element: _Element, scope: _Scope) -> None:
        first = self._node_locations.get(node.full_name)
        if first is not None:
            raise self._error(
                f"node {node.full_name!r} is defined twice: {first} and {node.location}; "
                "give each node a unique name",
                element,
                scope,
            )
        self._node_locations[node.full_name] = node.location

    # ----------------------------------------------------------------- parameters

    def _param_global(self, element: _Element, scope: _Scope) -> None:
        self._param(element, scope, None)

    def _rosparam_global(self, element: _Element, scope: _Scope) -> None:
        self._rosparam(element, scope, None)

    def _param_name(
        self, name: str, element: _Element, scope: _Scope, node: NodeDescription | None
    ) -> str:
        """Absolute name of a parameter: private inside a node, else relative to the scope."""
        if name.startswith("/"):
            return normalize_namespace(name)
        if node is None:
            if name.startswith("~"):
                raise self._error(
                    f"private parameter name {name!r} is only allowed inside a <node>",
                    element,
                    scope,
                )
            return join(scope.namespace, name)
        if name.startswith("~"):
            return expand(name, node.namespace, node.name)
        return join(node.full_name, name)

    def _param(
        self, element: _Element, scope: _Scope, node: NodeDescription | None, prefix: str = ""
    ) -> None:
        if "from" in element.attrs:
            self._params_file(element, scope, node)
            return
        name = prefix + self._required(element, scope, "name")
        children = self._active_children(element, scope)
        if children:
            self._nested_params(element, children, scope, node, name)
            return
        value = self._param_value(name, element, scope, node)
        self._set_tree(self._param_name(name, element, scope, node), value)

    def _nested_params(
        self,
        element: _Element,
        children: list[_Element],
        scope: _Scope,
        node: NodeDescription | None,
        name: str,
    ) -> None:
        if "value" in element.attrs:
            raise self._error(
                f"<param name={name!r}> has both value= and nested <param>s", element, scope
            )
        for child in children:
            if child.tag != "param":
                raise self._error(f"<{child.tag}> is not allowed inside <param>", child, scope)
            if "from" in child.attrs:
                raise self._error("nested <param> cannot have from=", child, scope)
            self._param(child, scope, node, prefix=name.rstrip("/") + "/")

    def _param_value(
        self, name: str, element: _Element, scope: _Scope, node: NodeDescription | None
    ) -> Any:
        for unsupported in ("command", "binfile"):
            if unsupported in element.attrs:
                raise self._error(
                    f"<param name={name!r}>: {unsupported}= is not supported "
                    "(rtcf does not run shell commands or load binary files)",
                    element,
                    scope,
                )
        textfile = self._attr(element, scope, "textfile")
        if textfile is not None:
            return self._read_text(self._path(textfile, scope), element, scope)
        value = self._attr(element, scope, "value")
        if value is None:
            raise self._error(f"<param name={name!r}> needs value= or textfile=", element, scope)
        ptype = self._attr(element, scope, "type")
        separator = self._attr(element, scope, "value-sep")
        if separator is not None:
            items = value.split(separator) if value else []
            return [self._typed(name, item, ptype, element, scope, node) for item in items]
        return self._typed(name, value, ptype, element, scope, node)

    def _typed(
        self,
        name: str,
        value: str,
        ptype: str | None,
        element: _Element,
        scope: _Scope,
        node: NodeDescription | None,
    ) -> Any:
        if ptype is None:
            ros2 = node is not None and node.dialect == "ros2"
            return _infer_ros2(value) if ros2 else _infer_ros1(value)
        kind = _TYPE_ALIASES.get(ptype.strip().lower(), ptype.strip().lower())
        if kind not in _PARAM_TYPES:
            raise self._error(
                f"<param name={name!r}>: unknown type {ptype!r}; use one of "
                + ", ".join(_PARAM_TYPES),
                element,
                scope,
            )
        converters: dict[str, Callable[[str], Any]] = {
            "str": str,
            "int": lambda v: int(v.strip()),
            "double": lambda v: float(v.strip()),
            "bool": lambda v: self._bool(v, f"param {name!r} value", element, scope),
            "yaml": lambda v: self._yaml(v, element, scope),
            "auto": _infer_ros1,
        }
        try:
            return converters[kind](value)
        except ValueError:
            raise self._error(
                f"<param name={name!r}>: {value!r} is not a valid {kind}", element, scope
            ) from None

    def _params_file(self, element: _Element, scope: _Scope, node: NodeDescription | None) -> None:
        if node is None:
            raise self._error("<param from=...> is only allowed inside a <node>", element, scope)
        path = self._path(self._required(element, scope, "from"), scope)
        data = self._yaml(self._read_text(path, element, scope), element, scope, file=path)
        if not isinstance(data, dict):
            raise LaunchError(
                "a ROS 2 parameters file must map node names to {ros__parameters: {...}}",
                file=path,
            )
        for key, entry in data.items():
            if not _params_file_key_matches(str(key), node):
                continue
            if not isinstance(entry, dict) or not isinstance(entry.get("ros__parameters"), dict):
                raise LaunchError(f"entry {key!r} has no 'ros__parameters' mapping", file=path)
            self._set_tree(node.full_name, entry["ros__parameters"])

    def _rosparam(self, element: _Element, scope: _Scope, node: NodeDescription | None) -> None:
        command = self._attr(element, scope, "command") or "load"
        target = _rel_join(
            self._attr(element, scope, "ns") or "", self._attr(element, scope, "param") or ""
        )
        base = node.full_name if node is not None else scope.namespace
        full = self._param_name(target, element, scope, node) if target else base
        if command == "dump":
            self._warn('<rosparam command="dump"> is ignored', element, scope)
        elif command == "delete":
            if not target:
                raise self._error('<rosparam command="delete"> needs param= or ns=', element, scope)
            self.description.parameters.delete(full)
        elif command == "load":
            self._rosparam_load(element, scope, full, bool(target))
        else:
            raise self._error(
                f"<rosparam command={command!r}>: use load, delete or dump", element, scope
            )

    def _rosparam_load(self, element: _Element, scope: _Scope, full: str, named: bool) -> None:
        file = self._attr(element, scope, "file")
        path = None if file is None else self._path(file, scope)
        text = element.text if path is None else self._read_text(path, element, scope)
        if self._bool_attr(element, scope, "subst_value", False):
            text = self._subst(text, element, scope)
        if not text.strip():
            raise self._error("<rosparam> is empty; give YAML text or file=", element, scope)
        value = self._yaml(text, element, scope, file=path)
        if not named and not isinstance(value, dict):
            raise self._error(
                "<rosparam> without param= must hold a YAML dictionary", element, scope
            )
        self._set_tree(full, value)


_LAUNCH_HANDLERS: dict[str, _Handler] = {
    "arg": _Loader._arg,
    "let": _Loader._let,
    "group": _Loader._group,
    "include": _Loader._include,
    "node": _Loader._node,
    "param": _Loader._param_global,
    "rosparam": _Loader._rosparam_global,
    "remap": _Loader._remap,
    "set_remap": _Loader._remap,
    "set-remap": _Loader._remap,
    "env": _Loader._env,
    "set_env": _Loader._env,
    "set-env": _Loader._env,
    "push-ros-namespace": _Loader._push_ros_namespace,
    "push_ros_namespace": _Loader._push_ros_namespace,
    "machine": _Loader._ignore,
    "test": _Loader._ignore,
    "set_parameter": _Loader._not_supported,
    "set-parameter": _Loader._not_supported,
}
