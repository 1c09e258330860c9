"""ROS graph-name rules: validation, expansion against a namespace, remapping.

The rules are those of ROS 1 and ROS 2 for topic and parameter names:

* ``/abs/name`` is absolute;
* ``~name`` is private: it lives under the node's own name, ``/ns/node/name``;
* ``rel/name`` is relative to the node's namespace, ``/ns/rel/name``.

Remapping takes a rule ``from -> to`` whose two sides are expanded the same way; a
name is expanded first, then looked up among the expanded ``from`` sides. When one
``from`` appears several times, the last rule wins (as in ``ros::init``).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def validate_name(name: str, *, what: str = "name") -> str | None:
    """Return why ``name`` is not a valid graph name, or None if it is."""
    if not name:
        return f"{what} is empty"
    body = name
    if body.startswith("~"):
        body = body[1:].lstrip("/")
        if not body:
            return None  # "~" alone names the node itself
    elif body.startswith("/"):
        body = body[1:]
        if not body:
            return None  # "/" is the root namespace
    if body.endswith("/"):
        return f"{what} {name!r} ends with '/'"
    for token in body.split("/"):
        if not token:
            return f"{what} {name!r} contains '//'"
        if not _TOKEN.match(token):
            return (
                f"{what} {name!r}: each part must start with a letter or '_' and hold only "
                "letters, digits and '_'"
            )
    return None


def normalize_namespace(namespace: str | None) -> str:
    """Return ``namespace`` as an absolute namespace: '/' or '/a/b' (no trailing slash)."""
    if not namespace:
        return "/"
    ns = namespace if namespace.startswith("/") else "/" + namespace
    ns = re.sub(r"/+", "/", ns)
    if len(ns) > 1 and ns.endswith("/"):
        ns = ns[:-1]
    return ns


def join(namespace: str, name: str) -> str:
    """Join an absolute namespace and a relative name."""
    ns = normalize_namespace(namespace)
    if not name:
        return ns
    return ns + name if ns == "/" else f"{ns}/{name}"


def expand(name: str, namespace: str, node_name: str | None = None) -> str:
    """Expand ``name`` to an absolute name, as seen by node ``node_name`` in ``namespace``."""
    if name.startswith("/"):
        return normalize_namespace(name)
    if name.startswith("~"):
        if node_name is None:
            raise ValueError(f"private name {name!r} needs a node")
        base = join(namespace, node_name)
        rest = name[1:].lstrip("/")
        return join(base, rest) if rest else base
    return join(namespace, name)


def namespace_of(name: str) -> str:
    """Return the namespace that holds absolute ``name``: ``/a/b/c`` -> ``/a/b``."""
    head, _, _ = normalize_namespace(name).rpartition("/")
    return head or "/"


def basename(name: str) -> str:
    """Return the last part of ``name``: ``/a/b/c`` -> ``c``."""
    return name.rstrip("/").rpartition("/")[2]


class Resolver:
    """Resolves names for one node: expansion against its namespace, then remapping."""

    __slots__ = ("_remaps", "namespace", "node_name")

    def __init__(
        self,
        namespace: str,
        node_name: str,
        remaps: Iterable[tuple[str, str]] | Mapping[str, str] = (),
    ) -> None:
        self.namespace = normalize_namespace(namespace)
        self.node_name = node_name
        pairs = remaps.items() if isinstance(remaps, Mapping) else remaps
        self._remaps: dict[str, str] = {}
        for src, dst in pairs:
            # later rules override earlier ones with the same source, as in ROS
            self._remaps[self.expand(src)] = self.expand(dst)

    def expand(self, name: str) -> str:
        return expand(name, self.namespace, self.node_name)

    def resolve(self, name: str) -> str:
        """Expand ``name`` and apply this node's remapping rules."""
        full = self.expand(name)
        return self._remaps.get(full, full)

    def private(self, name: str = "") -> str:
        return self.expand("~" + name if name else "~")

    @property
    def remaps(self) -> dict[str, str]:
        return dict(self._remaps)
