"""Substitution arguments ``$(...)`` of ROS 1 and ROS 2 launch XML.

Supported: ``$(arg x)``, ``$(var x)``, ``$(env VAR)``, ``$(env VAR default)``,
``$(optenv VAR default words)``, ``$(find pkg)``, ``$(find-pkg-share pkg)``,
``$(dirname)``, ``$(anon name)``, ``$(eval expr)``, and ROS 2's ``$(find-exec name)``
and ``$(command 'program args' [on_stderr])`` (:mod:`._commands`: run once, as the
file is read). Substitutions nest, as in ROS 2: a substitution's arguments are split
into words first (quotes group words, a nested ``$(...)`` is one word with its
spaces), then the inner ones are expanded (``$(find-pkg-share $(var pkg))``,
``$(command '$(find-exec xacro) $(var model)')``).

Errors are raised as :class:`SubstitutionError` with a message only; the launch
reader adds the file and line of the attribute.
"""

from __future__ import annotations

import importlib.util
import math
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol

from . import _commands


class SubstitutionError(Exception):
    """A ``$(...)`` cannot be expanded; the message says which and why."""


class SubstitutionContext(Protocol):
    """What substitutions need from the launch reader."""

    def arg(self, name: str, *, strict: bool) -> str:
        """Value of arg/launch configuration ``name``.

        ``strict`` (``$(arg)``) sees only the args of the current file; otherwise
        (``$(var)``) configurations inherited from an including file are visible too.
        """
        ...

    def variables(self) -> Mapping[str, str]:
        """All visible args/configurations with a value (for ``$(eval)``)."""
        ...

    def dirname(self) -> str: ...

    def anon(self, name: str) -> str: ...

    def find_package(self, name: str) -> str: ...

    def environment(self) -> Mapping[str, str]:
        """What the file set in the environment so far (``<set_env>``, ``<env>``)."""
        ...

    def warn(self, message: str) -> None:
        """Report ``message`` as a warning of the file (it adds file and line)."""
        ...


_EVAL_BUILTINS: dict[str, Any] = {
    f.__name__: f
    for f in (
        abs,
        all,
        any,
        bool,
        dict,
        float,
        int,
        len,
        list,
        max,
        min,
        range,
        round,
        sorted,
        str,
        sum,
        tuple,
    )
}
_MATH = {k: v for k, v in vars(math).items() if not k.startswith("_")}


def substitute(text: str, context: SubstitutionContext) -> str:
    """Return ``text`` with every ``$(...)`` expanded."""
    out: list[str] = []
    pos = 0
    while True:
        start = text.find("$(", pos)
        if start < 0:
            out.append(text[pos:])
            return "".join(out)
        out.append(text[pos:start])
        end = _closing_paren(text, start + 1)
        if end < 0:
            raise SubstitutionError(f"unterminated '$(' in {text!r}")
        out.append(_expand(text[start + 2 : end], context))
        pos = end + 1


def _closing_paren(text: str, open_index: int) -> int:
    depth = 0
    for index in range(open_index, len(text)):
        if text[index] == "(":
            depth += 1
        elif text[index] == ")":
            depth -= 1
            if depth == 0:
                return index
    return -1


def _expand(body: str, context: SubstitutionContext) -> str:
    parts = body.strip().split(None, 1)
    if not parts:
        raise SubstitutionError("empty substitution '$()'")
    kind = parts[0]
    raw = parts[1] if len(parts) > 1 else ""
    if kind == "eval":
        return _eval(substitute(raw, context), context)
    handler = _HANDLERS.get(kind)
    if handler is None:
        known = ", ".join(sorted([*_HANDLERS, "eval"]))
        raise SubstitutionError(f"unknown substitution '$({kind} ...)'; known ones: {known}")
    return handler([substitute(word, context) for word in split_words(raw)], context)


def split_words(text: str) -> list[str]:
    """A substitution's arguments as words, before their own substitutions are expanded:
    split at whitespace, except inside quotes (``'...'``, ``"..."``, which are removed) and
    inside a nested ``$(...)``, which stays one word with its quotes and spaces."""
    words: list[str] = []
    current: list[str] = []
    started = False  # '' is a word too
    quote = ""
    depth = 0
    index = 0
    while index < len(text):
        char = text[index]
        if text.startswith("$(", index):
            current.append("$(")
            depth += 1
            started = True
            index += 2
            continue
        if depth:
            depth += {"(": 1, ")": -1}.get(char, 0)
            current.append(char)
        elif quote:
            if char == quote:
                quote = ""
            else:
                current.append(char)
        elif char in "'\"":
            quote = char
            started = True
        elif char.isspace():
            if started:
                words.append("".join(current))
                current, started = [], False
        else:
            current.append(char)
            started = True
        index += 1
    if quote:
        raise SubstitutionError(f"unterminated quote {quote} in {text!r}")
    if started:
        words.append("".join(current))
    return words


def _want(kind: str, words: list[str], low: int, high: int | None) -> None:
    if len(words) < low or (high is not None and len(words) > high):
        if high is None:
            count = f"at least {low}"
        else:
            count = str(low) if low == high else f"{low} to {high}"
        raise SubstitutionError(f"$({kind}) takes {count} argument(s), got {len(words)}")


def _arg(words: list[str], context: SubstitutionContext) -> str:
    _want("arg", words, 1, 1)
    return context.arg(words[0], strict=True)


def _var(words: list[str], context: SubstitutionContext) -> str:
    _want("var", words, 1, 1)
    return context.arg(words[0], strict=False)


def _env(words: list[str], context: SubstitutionContext) -> str:
    _want("env", words, 1, 2)
    value = os.environ.get(words[0])
    if value is not None:
        return value
    if len(words) == 2:
        return words[1]
    raise SubstitutionError(
        f"environment variable {words[0]!r} is not set; set it or use $(optenv {words[0]} default)"
    )


def _optenv(words: list[str], context: SubstitutionContext) -> str:
    _want("optenv", words, 1, None)
    return os.environ.get(words[0], " ".join(words[1:]))


def _find(words: list[str], context: SubstitutionContext) -> str:
    _want("find", words, 1, 1)
    return context.find_package(words[0])


def _dirname(words: list[str], context: SubstitutionContext) -> str:
    _want("dirname", words, 0, 0)
    return context.dirname()


def _anon(words: list[str], context: SubstitutionContext) -> str:
    _want("anon", words, 1, 1)
    return context.anon(words[0])


def _find_exec(words: list[str], context: SubstitutionContext) -> str:
    _want("find-exec", words, 1, 1)
    found = _commands.find_executable(words[0])
    if found is None:
        raise SubstitutionError(
            f"$(find-exec {words[0]}): executable {words[0]!r} not found on the PATH "
            f"(nor in {_commands.scripts_directory()})"
        )
    return found


def _command(words: list[str], context: SubstitutionContext) -> str:
    """launch's Command: the program's stdout; ``on_stderr`` says what its stderr does."""
    _want("command", words, 1, 2)
    on_stderr = words[1] if len(words) == 2 else "fail"
    shown = f"$(command '{_commands.one_line(words[0])}')"
    if on_stderr not in _commands.ON_STDERR:
        raise SubstitutionError(
            f"{shown}: on_stderr is {on_stderr!r}; use one of " + ", ".join(_commands.ON_STDERR)
        )
    try:
        output = _commands.run(
            words[0], capture_stderr=on_stderr == "capture", extra_env=context.environment()
        )
    except _commands.CommandFailed as exc:
        raise SubstitutionError(f"{shown} failed: {exc}") from None
    if output.stderr.strip() and on_stderr in ("fail", "warn"):
        said = f"{shown} wrote to stderr: {_commands.first_lines(output.stderr)}"
        if on_stderr == "fail":
            raise SubstitutionError(
                f"{said} (on_stderr 'fail', the default; give 'warn' or 'ignore' as its "
                "second argument to go on)"
            )
        context.warn(said)
    return output.stdout


_HANDLERS: dict[str, Callable[[list[str], SubstitutionContext], str]] = {
    "arg": _arg,
    "var": _var,
    "env": _env,
    "optenv": _optenv,
    "find": _find,
    "find-pkg-share": _find,
    "dirname": _dirname,
    "anon": _anon,
    "find-exec": _find_exec,
    "command": _command,
}


def roslaunch_auto(value: str) -> Any:
    """An arg's value as roslaunch's ``$(eval)`` sees it (its ``convert_value(value,
    'auto')``): an int, or a float where there is a ``.``, else ``true``/``false`` in any
    case as a bool, else the string. So ``$(eval 5 if use_ros else 4)`` with
    ``use_ros:=true`` is 5, and ``use_ros == 'true'`` is False, in roslaunch and here."""
    try:
        return float(value) if "." in value else int(value)
    except ValueError:
        pass
    if value.lower() in ("true", "false"):
        return value.lower() == "true"
    return value


def _eval(expression: str, context: SubstitutionContext) -> str:
    """Evaluate a Python expression with the args as variables (ROS 1 and ROS 2 style)."""
    expr = expression.strip()
    if len(expr) >= 2 and expr[0] == expr[-1] and expr[0] in "'\"":
        expr = expr[1:-1]  # ROS 2 writes $(eval "expression")
    if "__" in expr:
        raise SubstitutionError(f"$(eval {expr}): '__' is not allowed in expressions")

    def arg(name: str) -> Any:
        return roslaunch_auto(context.arg(name, strict=True))

    def optenv(name: str, default: str = "") -> str:
        return os.environ.get(name, default)

    def env(name: str) -> str:
        return _env([name], context)

    namespace: dict[str, Any] = {
        **_MATH,
        "true": True,
        "false": False,
        "arg": arg,
        "env": env,
        "optenv": optenv,
        "find": context.find_package,
        "anon": context.anon,
        "dirname": context.dirname,
        # an arg by its bare name (roslaunch's $(eval); ROS 2's eval has no names)
        **{name: roslaunch_auto(value) for name, value in context.variables().items()},
    }
    try:
        result = eval(expr, {"__builtins__": _EVAL_BUILTINS}, namespace)
    except SubstitutionError:
        raise
    except Exception as exc:
        raise SubstitutionError(f"$(eval {expr}) failed: {type(exc).__name__}: {exc}") from None
    return str(result)


def find_package(name: str, environ: Mapping[str, str] | None = None) -> str:
    """Return the directory of package ``name``.

    Looks in ``ROS_PACKAGE_PATH`` (each entry and up to two levels below it) for a
    directory whose ``package.xml`` names ``name`` (ROS 1), then in the ament index
    of each prefix on ``AMENT_PREFIX_PATH`` and then of this Python's prefix, where
    pip installs a package's data files (ROS 2: ``<prefix>/share/<name>``, as
    ``get_package_share_directory`` gives it), then for an importable Python
    package ``name``.
    """
    env = os.environ if environ is None else environ
    for root in filter(None, env.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        found = _search_package_path(Path(root), name)
        if found is not None:
            return str(found)
    prefixes = [*filter(None, env.get("AMENT_PREFIX_PATH", "").split(os.pathsep)), sys.prefix]
    for prefix in prefixes:
        share = _ament_share_directory(Path(prefix), name)
        if share is not None:
            return str(share)
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        spec = None
    if spec is not None:
        if spec.submodule_search_locations:
            return str(Path(next(iter(spec.submodule_search_locations))))
        if spec.origin:
            return str(Path(spec.origin).parent)
    raise SubstitutionError(
        f"package {name!r} not found: no package.xml naming it under ROS_PACKAGE_PATH, "
        "not in the ament index of AMENT_PREFIX_PATH or of this Python's prefix, "
        "and no importable Python package of that name"
    )


def _ament_share_directory(prefix: Path, name: str) -> Path | None:
    """``<prefix>/share/<name>`` if the prefix's ament index registers package ``name``.

    The look-up of ament_index_python (and so of ``ros2 launch``, ``ros2 run`` and
    launch_ros): the marker file ``share/ament_index/resource_index/packages/<name>``.
    A ``share/<name>/package.xml`` that names the package counts too.
    """
    share = prefix / "share" / name
    if (prefix / "share" / "ament_index" / "resource_index" / "packages" / name).is_file():
        return share
    if _package_name(share) == name:
        return share
    return None


def _search_package_path(root: Path, name: str, depth: int = 2) -> Path | None:
    if _package_name(root) == name:
        return root
    if depth == 0 or not root.is_dir():
        return None
    try:
        children = sorted(p for p in root.iterdir() if p.is_dir())
    except OSError:
        return None
    for child in children:
        found = _search_package_path(child, name, depth - 1)
        if found is not None:
            return found
    return None


def _package_name(directory: Path) -> str | None:
    manifest = directory / "package.xml"
    if not manifest.is_file():
        return None
    try:
        text = ET.parse(manifest).getroot().findtext("name")
    except (ET.ParseError, OSError):
        return None
    return text.strip() if text else None
