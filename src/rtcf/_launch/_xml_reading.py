"""What every element of a launch XML file is read with, in either dialect.

The XML tree keeps the line of each start tag (ElementTree drops line numbers, so
the XML is read with :mod:`xml.parsers.expat`); a :class:`Scope` is what is in force
at one point of a file (namespace, args, remaps, environment); a :class:`Reader`
reads an element's attributes in a scope (substitutions, booleans, paths, YAML),
names errors by file and line, and sets parameters in the description. The common
reader (:mod:`._xml`) and the dialects (:mod:`._xml_ros1`, :mod:`._xml_ros2`) share it.
"""

from __future__ import annotations

import os
import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple
from xml.parsers import expat

import yaml

from .._core._errors import LaunchError
from .._core._names import expand, join, normalize_namespace, validate_name
from ._description import LaunchDescription, NodeDescription
from ._substitutions import SubstitutionError, find_package, substitute

# --------------------------------------------------------------------------- XML tree


@dataclass
class Element:
    tag: str
    attrs: dict[str, str]
    line: int
    children: list[Element] = field(default_factory=list)
    text_parts: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        return "".join(self.text_parts)


def parse_xml(data: str | bytes, file: str) -> Element:
    parser = expat.ParserCreate()
    parser.buffer_text = True
    stack: list[Element] = []
    roots: list[Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = Element(tag, attrs, parser.CurrentLineNumber)
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


class Config(NamedTuple):
    """An arg or launch configuration; ``inherited`` ones come from an including file."""

    value: str | None
    inherited: bool = False


@dataclass
class LaunchFile:
    """One launch file being read, with the args passed to it."""

    path: str  # as shown in messages
    directory: str  # absolute, for relative paths and $(dirname)
    passed: dict[str, str]
    explicit: set[str]  # passed by name (not by pass_all_args): constants may not be overridden
    declared: dict[str, str | None] = field(default_factory=dict)  # arg name -> final value


@dataclass
class Scope:
    """What is in force at one point of a file: namespace, args, remaps, environment."""

    file: LaunchFile
    namespace: str = "/"
    configs: dict[str, Config] = field(default_factory=dict)
    declared: dict[str, int] = field(default_factory=dict)  # arg name -> line, for duplicates
    remaps: list[tuple[str, str]] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)

    def child(self) -> Scope:
        return Scope(
            self.file,
            self.namespace,
            dict(self.configs),
            dict(self.declared),
            list(self.remaps),
            dict(self.env),
        )


class Substitutions:
    """The substitution context of one scope (see ``_substitutions.SubstitutionContext``)."""

    def __init__(self, reader: Reader, scope: Scope, element: Element) -> None:
        self._reader = reader
        self._scope = scope
        self._element = element

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
        return self._reader.anon(name)

    def find_package(self, name: str) -> str:
        return self._reader.find_package(name)

    def environment(self) -> dict[str, str]:
        return dict(self._scope.env)

    def warn(self, message: str) -> None:
        self._reader.warn(message, self._element, self._scope)


def push_namespace(current: str, ns: str | None) -> str:
    if not ns:
        return current
    return normalize_namespace(ns) if ns.startswith("/") else join(current, ns)


# --------------------------------------------------------------------------- reading

TRUE = ("true", "1")
FALSE = ("false", "0")

Handler = Callable[[Element, Scope], None]


class Reader:
    """Reads elements of one launch file and its includes into one LaunchDescription."""

    def __init__(self, description: LaunchDescription) -> None:
        self.description = description
        self._anon: dict[str, str] = {}
        self._rng = random.Random()
        self._packages: dict[str, str] = {}

    def anon(self, name: str) -> str:
        if name not in self._anon:
            self._anon[name] = f"{name}_{self._rng.getrandbits(48):012x}"
        return self._anon[name]

    def find_package(self, name: str) -> str:
        if name not in self._packages:
            self._packages[name] = find_package(name)
        return self._packages[name]

    def error(self, message: str, element: Element, scope: Scope) -> LaunchError:
        return LaunchError(message, file=scope.file.path, line=element.line)

    def warn(self, message: str, element: Element, scope: Scope) -> None:
        self.description.warnings.append(f"{scope.file.path}:{element.line}: {message}")

    def subst(self, text: str, element: Element, scope: Scope) -> str:
        try:
            return substitute(text, Substitutions(self, scope, element))
        except SubstitutionError as exc:
            raise self.error(str(exc), element, scope) from None

    def attr(self, element: Element, scope: Scope, name: str) -> str | None:
        raw = element.attrs.get(name)
        return None if raw is None else self.subst(raw, element, scope)

    def required(self, element: Element, scope: Scope, name: str) -> str:
        value = self.attr(element, scope, name)
        if value is None:
            raise self.error(f"<{element.tag}> needs attribute {name!r}", element, scope)
        return value

    def boolean(self, value: str, what: str, element: Element, scope: Scope) -> bool:
        lowered = value.strip().lower()
        if lowered in TRUE:
            return True
        if lowered in FALSE:
            return False
        raise self.error(
            f"{what}={value!r} is not a boolean; use true, false, 1 or 0", element, scope
        )

    def bool_attr(self, element: Element, scope: Scope, name: str, default: bool) -> bool:
        value = self.attr(element, scope, name)
        return default if value is None else self.boolean(value, name, element, scope)

    def active(self, element: Element, scope: Scope) -> bool:
        if_value = self.attr(element, scope, "if")
        if if_value is not None and not self.boolean(if_value, "if", element, scope):
            return False
        unless_value = self.attr(element, scope, "unless")
        return unless_value is None or not self.boolean(unless_value, "unless", element, scope)

    def active_children(self, element: Element, scope: Scope) -> list[Element]:
        return [c for c in element.children if self.active(c, scope)]

    def path(self, raw: str, scope: Scope) -> str:
        path = os.path.expanduser(raw)
        if os.path.isabs(path):
            return os.path.normpath(path)
        return os.path.normpath(os.path.join(scope.file.directory, path))

    def read_text(self, path: str, element: Element, scope: Scope) -> str:
        try:
            return Path(path).read_text(encoding="utf-8")
        except OSError as exc:
            raise self.error(f"cannot read {path!r}: {exc.strerror}", element, scope) from None

    def read_bytes(self, path: str, element: Element, scope: Scope) -> bytes:
        try:
            return Path(path).read_bytes()
        except OSError as exc:
            raise self.error(f"cannot read {path!r}: {exc.strerror}", element, scope) from None

    def parse_yaml(self, text: str, element: Element, scope: Scope, file: str | None = None) -> Any:
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

    def namespace(self, raw: str | None, current: str, element: Element, scope: Scope) -> str:
        namespace = push_namespace(current, raw)
        problem = validate_name(namespace, what="namespace")
        if problem:
            raise self.error(problem, element, scope)
        return namespace

    def set_tree(self, name: str, value: Any) -> None:
        """Set ``value`` at ``name``, merging dicts leaf by leaf into what is there."""
        if isinstance(value, Mapping) and value:
            for key, sub in value.items():
                self.set_tree(f"{name.rstrip('/')}/{key}", sub)
        else:
            self.description.parameters.set(name, value)

    # what is in force for the rest of a scope: both dialects' tags for it call these

    def remap(self, element: Element, scope: Scope) -> None:
        scope.remaps.append(self.remap_rule(element, scope))

    def remap_rule(self, element: Element, scope: Scope) -> tuple[str, str]:
        return self.required(element, scope, "from"), self.required(element, scope, "to")

    def env(self, element: Element, scope: Scope) -> None:
        scope.env[self.required(element, scope, "name")] = self.required(element, scope, "value")

    def param_name(
        self, name: str, element: Element, scope: Scope, node: NodeDescription | None
    ) -> str:
        """Absolute name of a parameter: private inside a node, else relative to the scope."""
        if name.startswith("/"):
            return normalize_namespace(name)
        if node is None:
            if name.startswith("~"):
                raise self.error(
                    f"private parameter name {name!r} is only allowed inside a <node>",
                    element,
                    scope,
                )
            return join(scope.namespace, name)
        if name.startswith("~"):
            return expand(name, node.namespace, node.name)
        return join(node.full_name, name)
