"""Finding a component class from ``MODULE ClassName``, with errors that say what to do."""

from __future__ import annotations

import importlib

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

