"""Parameters: a ROS-style hierarchical parameter tree and a component's view of it.

The tree is stored as flat leaves, ``{"/ns/node/gain": 2.0}``. Setting a dict sets
its leaves; getting a namespace assembles a dict, as the ROS 1 parameter server does.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from ._errors import ComponentError, ConfigurationError
from ._names import Resolver, normalize_namespace
from ._tunables import Tunable, declare

_TUNABLE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")

_MISSING: Any = object()


class ParameterStore:
    """A parameter tree keyed by absolute names (the launch file's parameter server)."""

    def __init__(self, values: Mapping[str, Any] | None = None) -> None:
        self._leaves: dict[str, Any] = {}
        # told (absolute name, value) when a component sets a parameter: a worker
        # passes it on, so that the middleware's parameters follow (not for loads)
        self.observer: Callable[[str, Any], None] | None = None
        for name, value in (values or {}).items():
            self.set(name, value)

    def set(self, name: str, value: Any) -> None:
        """Set absolute ``name``; a dict value replaces the whole subtree under it."""
        key = normalize_namespace(name)
        self.delete(key)
        if isinstance(value, Mapping) and value:
            for sub, subvalue in value.items():
                self.set(key.rstrip("/") + "/" + str(sub), subvalue)
        else:
            self._leaves[key] = value

    def delete(self, name: str) -> None:
        key = normalize_namespace(name)
        prefix = key.rstrip("/") + "/"
        for leaf in [k for k in self._leaves if k == key or k.startswith(prefix)]:
            del self._leaves[leaf]

    def has(self, name: str) -> bool:
        key = normalize_namespace(name)
        prefix = key.rstrip("/") + "/"
        return key in self._leaves or any(k.startswith(prefix) for k in self._leaves)

    def get(self, name: str, default: Any = _MISSING) -> Any:
        """Return the value at absolute ``name`` (a dict for a namespace)."""
        key = normalize_namespace(name)
        if key in self._leaves:
            return self._leaves[key]
        prefix = key.rstrip("/") + "/"
        sub = {k[len(prefix) :]: v for k, v in self._leaves.items() if k.startswith(prefix)}
        if not sub:
            if default is _MISSING:
                raise KeyError(key)
            return default
        tree: dict[str, Any] = {}
        for rel, value in sorted(sub.items()):
            node = tree
            *parents, leaf = rel.split("/")
            for part in parents:
                node = node.setdefault(part, {})
            node[leaf] = value
        return tree

    def update(self, other: ParameterStore) -> None:
        for name, value in other.items():
            self._leaves[name] = value

    def items(self) -> Iterator[tuple[str, Any]]:
        return iter(sorted(self._leaves.items()))

    def names(self) -> list[str]:
        return sorted(self._leaves)

    def as_dict(self) -> dict[str, Any]:
        return dict(self.items())

    def __len__(self) -> int:
        return len(self._leaves)

    def __repr__(self) -> str:
        return f"ParameterStore({self.as_dict()!r})"


class Params:
    """A component's access to parameters, with ROS name rules.

    ``~name`` is private (under the component's own name), ``name`` is relative to
    the component's namespace, ``/name`` is absolute. Read them in ``configure``.
    """

    __slots__ = (
        "_component", "_resolver", "_running", "_store", "declared", "previous", "sealed"
    )

    def __init__(
        self,
        store: ParameterStore,
        resolver: Resolver,
        component: str,
        running: Callable[[], bool] | None = None,
    ) -> None:
        self._store = store
        self._running = running  # whether update() runs now (set() is refused there)
        self._resolver = resolver
        self._component = component
        self.declared: dict[str, Tunable[Any]] = {}  # tunable parameters by name
        self.sealed = False  # set after configure: no more declarations
        # while configure runs again (lifecycle): the tunables of the first configure
        self.previous: dict[str, Tunable[Any]] | None = None

    def resolve(self, name: str) -> str:
        """Return the absolute name that ``name`` stands for."""
        return self._resolver.expand(name)

    def has(self, name: str) -> bool:
        """Whether a parameter (or a namespace of them) exists at ``name``."""
        return self._store.has(self.resolve(name))

    def get(self, name: str, default: Any = _MISSING) -> Any:
        """Return the parameter at ``name``, or ``default`` when it is not set.

        Without a default, a missing parameter is an error that names it.
        """
        full = self.resolve(name)
        try:
            return self._store.get(full)
        except KeyError:
            if default is _MISSING:
                raise ConfigurationError(
                    f"component {self._component!r}: parameter {full!r} (asked as {name!r}) "
                    "is not set; set it in the launch file or pass a default"
                ) from None
            return default

    def set(self, name: str, value: Any) -> None:
        """Set a parameter, as the original's node handle does (``setParam``).

        Non-real-time: call it from configure, start, stop or cleanup, not from
        update. Under a middleware the value is written back where that middleware
        keeps parameters (the ROS 1 parameter server; the component node's parameters
        on ROS 2); on the embedded default, to the launch file's parameter tree.
        """
        if self._running is not None and self._running():
            raise ComponentError(
                f"component {self._component!r}: params.set({name!r}) in update(): setting "
                "a parameter is not real-time safe; set it in configure or start, or use a "
                "tunable parameter (params.declare) or an output port",
                component=self._component,
            )
        full = self.resolve(name)
        self._store.set(full, value)
        observer = self._store.observer
        if observer is not None:
            observer(full, value)

    def declare(
        self,
        name: str,
        default: Any,
        *,
        description: str = "",
        min: float | None = None,
        max: float | None = None,
        choices: Sequence[Any] | None = None,
    ) -> Tunable[Any]:
        """Declare a tunable parameter (in ``configure``); read ``.value`` in ``update``.

        Its type is the default's (bool, int, float or str). It starts at the private
        parameter ``~name`` when the launch file sets one, else at ``default``.
        ``min``/``max`` bound numbers, ``choices`` lists the allowed values (an enum).
        Tools change it while the loop runs (ROS 2 ``set_parameters``, ROS 1
        ``dynparam``); the change is applied between two iterations.
        """
        bare = name[1:] if name.startswith("~") else name
        where = f"component {self._component!r}: tunable parameter {name!r}"
        if self.sealed:
            raise ConfigurationError(f"{where} is declared after configure(); declare it there")
        if not _TUNABLE_NAME.fullmatch(bare):
            raise ConfigurationError(
                f"{where}: a tunable parameter's name is a letter followed by letters, "
                "digits and underscores"
            )
        if bare in self.declared:
            raise ConfigurationError(f"{where} is declared twice")
        initial = self._store.get(self._resolver.private(bare), default)
        tunable = declare(
            self._component,
            bare,
            default,
            initial,
            description=description,
            min=min,
            max=max,
            choices=choices,
        )
        if self.previous is not None:  # configured again: the same declaration, same object
            first = self.previous.get(bare)
            if first is None or first.spec != tunable.spec:
                raise ConfigurationError(
                    f"{where} is declared differently than by the first configure() (or not "
                    "at all then); configured again, a component must declare the same tunable "
                    "parameters: unload and load it to change them"
                )
            tunable = first  # its value is kept, as a ROS 2 node keeps its parameters
        self.declared[bare] = tunable
        return tunable
