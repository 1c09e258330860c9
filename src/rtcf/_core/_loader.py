"""Finding a component class from ``MODULE ClassName``, with errors that say what to do."""

from __future__ import annotations

import ast
import importlib
import sys
from collections.abc import Iterator
from typing import Any

from ._component import Component
from ._errors import ComponentError


def load_component_class(module: str, class_name: str, *, component: str = "") -> type[Component]:
    """Import ``module`` and return its ``class_name``, which must subclass Component."""
    who = f"component {component!r}: " if component else ""
    if not module or not class_name:
        raise ComponentError(
            f'{who}needs a module and a class, as in args="rtcf_examples PaperExample"',
            component=component,
        )
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        missing = exc.name or module
        hint = (
            f"module {module!r} is not found; install it or add its folder to PYTHONPATH"
            if missing == module.split(".")[0] or missing == module
            else f"importing module {module!r} failed: module {missing!r} is missing"
        )
        raise ComponentError(who + hint, component=component) from exc
    except Exception as exc:  # an error in the user's module itself
        raise ComponentError(
            f"{who}importing module {module!r} raised {type(exc).__name__}: {exc}",
            component=component,
        ) from exc
    cls = getattr(mod, class_name, None)
    if cls is None:
        available = sorted(
            n
            for n, v in vars(mod).items()
            if isinstance(v, type) and issubclass(v, Component) and v is not Component
        )
        hint = f"; it has {', '.join(available)}" if available else ""
        raise ComponentError(
            f"{who}module {module!r} ({getattr(mod, '__file__', '?')}) has no class "
            f"{class_name!r}{hint}",
            component=component,
        )
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise ComponentError(
            f"{who}{module}.{class_name} is not a subclass of rtcf.Component",
            component=component,
        )
    return cls



def absent_component_class(module: str, class_name: str, *, component: str = "") -> str | None:
    """Why ``module``'s ``class_name`` certainly cannot be loaded, found without
    importing or running any of it; None where only the import can tell.

    A running runner's services ask this before they stop the loop to load: only the
    worker may import (the loop stops for it), so a module or class that does not exist
    is refused here instead. The module is looked up by the import system's own finders
    (editable installs included) on the worker's ``sys.path``, which is the caller's;
    the class, in the module's source: a name bound nowhere at its top level. A module
    that binds names in ways the source does not show (``import *``, a module
    ``__getattr__``, ``globals()``) is left to the import."""
    who = f"component {component!r}: " if component else ""
    spec = _find_spec(module)
    if spec is _UNKNOWN:
        return None
    if spec is None:
        return f"{who}module {module!r} is not found; install it or add its folder to PYTHONPATH"
    origin = getattr(spec, "origin", None)
    if not isinstance(origin, str) or not origin.endswith(".py"):
        return None  # an extension, a namespace package, a frozen module: the import tells
    try:
        with open(origin, "rb") as f:
            tree = ast.parse(f.read(), origin)
    except (OSError, SyntaxError, ValueError):
        return None  # the import says what is wrong with it
    bound = _top_level_names(tree)
    if bound is None or class_name in bound:
        return None
    return f"{who}module {module!r} ({origin}) has no class {class_name!r}"


_UNKNOWN = object()


def _find_spec(module: str) -> Any:
    """The module's spec, found by the meta path's finders without importing its
    packages (importlib.util.find_spec imports them); None: not found; _UNKNOWN: the
    finders cannot tell (a name that is no module path, a finder that raised)."""
    parts = module.split(".")
    if not all(p.isidentifier() for p in parts):
        return _UNKNOWN
    if module in sys.modules:
        return getattr(sys.modules[module], "__spec__", None) or _UNKNOWN
    path = None
    spec = None
    for i in range(len(parts)):
        name = ".".join(parts[: i + 1])
        loaded = sys.modules.get(name)
        if loaded is not None:
            spec = getattr(loaded, "__spec__", None)
            if spec is None:
                return _UNKNOWN
        else:
            spec = None
            for finder in sys.meta_path:
                find = getattr(finder, "find_spec", None)
                if find is None:
                    continue
                try:
                    spec = find(name, path)
                except Exception:  # a finder's own trouble: the import will say it
                    return _UNKNOWN
                if spec is not None:
                    break
            if spec is None:
                return None
        if i < len(parts) - 1:
            path = getattr(spec, "submodule_search_locations", None)
            if path is None:  # a plain module's attribute (os.path): the import tells
                return _UNKNOWN
            path = list(path)
    return spec


def _top_level_names(tree: ast.Module) -> set[str] | None:
    """Every name a module's source binds outside its functions and classes (in ifs,
    trys, loops and withs too); None if it may bind names the source does not show."""
    for node in ast.walk(tree):  # a function the module calls may bind them too
        if isinstance(node, ast.Name) and node.id in _BINDS_BY_VALUE:
            return None
        if isinstance(node, ast.Attribute) and node.attr == "modules":
            return None  # sys.modules[__name__] = ...: the module replaces itself
    names: set[str] = set()
    for node in _top_level_nodes(tree.body):
        if isinstance(node, ast.ImportFrom) and any(a.name == "*" for a in node.names):
            return None
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            names.add(node.name)
        elif isinstance(node, (ast.MatchAs, ast.MatchStar)) and node.name:
            names.add(node.name)
    return None if "__getattr__" in names else names


_BINDS_BY_VALUE = frozenset({"globals", "vars", "exec", "setattr", "__dict__"})


def _top_level_nodes(body: list[ast.stmt]) -> Iterator[ast.AST]:
    """The nodes of a module's statements, not descending into functions, classes or
    lambdas (their names are their own), but into ifs, trys, loops and withs."""
    stack: list[ast.AST] = list(reversed(body))
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            stack.extend(node.decorator_list)  # evaluated at the top level
            continue
        if isinstance(node, ast.Lambda):
            continue
        stack.extend(ast.iter_child_nodes(node))
