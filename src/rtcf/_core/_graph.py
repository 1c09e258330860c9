"""The data-flow graph: connections between ports, and the execution order.

Ports are connected when their resolved topic names are equal. The execution
order is a topological sort with Kahn's algorithm; among the components that are
ready at the same time, the one whose full name sorts first (plain string order)
runs first, so the order never depends on load order or hashing.

An edge is left out of the ordering (but still carries data, one iteration late)
when its consumer has ``is_first`` set, or when its topic fully matches the
consumer's ``topics_ignore_for_graph`` pattern.
"""

from __future__ import annotations

import heapq
import re
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from ._errors import GraphError


@dataclass(frozen=True)
class PortInfo:
    component: str
    name: str
    topic: str
    type: type[Any]
    claimed: bool = False  # a claimed command: one of several writers, one active at a time

    @property
    def qualified_name(self) -> str:
        return f"{self.component}.{self.name}"


@dataclass
class GraphNode:
    """What the graph needs to know of one component."""

    name: str  # full name
    inputs: list[PortInfo] = field(default_factory=list)
    outputs: list[PortInfo] = field(default_factory=list)
    is_first: bool = False
    ignore_pattern: re.Pattern[str] | None = None
    label: str = ""  # e.g. the class name, for printing
    lane: str = "main"  # the lane (worker process) it runs in (rtcf._core._lanes)


@dataclass(frozen=True)
class Edge:
    """One connection: ``producer`` output to ``consumer`` input on ``topic``."""

    topic: str
    producer: PortInfo
    consumer: PortInfo
    # None, "is_first", "topics_ignore_for_graph" or "logical execution time" (lanes)
    ignored_by: str | None = None

    @property
    def orders(self) -> bool:
        """Whether this edge constrains the execution order."""
        return self.ignored_by is None


@dataclass
class Graph:
    nodes: list[GraphNode]
    edges: list[Edge]
    order: list[str]
    unconnected_inputs: list[PortInfo]
    unconsumed_outputs: list[PortInfo]
    warnings: list[str] = field(default_factory=list)

    def topics(self) -> list[str]:
        names = {p.topic for n in self.nodes for p in (*n.inputs, *n.outputs)}
        return sorted(names)


def types_compatible(produced: type[Any], consumed: type[Any]) -> bool:
    """An input accepts its own type, a subclass of it, or anything if it is ``object``."""
    return consumed is object or produced is consumed or issubclass(produced, consumed)


def build_graph(nodes: Sequence[GraphNode], let_lanes: Collection[str] = ()) -> Graph:
    """Connect ports by topic, check types and producers, and order the components.

    An edge between two lanes one of which runs on logical execution time (``let_lanes``)
    does not order: the value crosses at a release or a window's end, not in the
    iteration's order.
    """
    names = [n.name for n in nodes]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise GraphError(f"component {dupes[0]!r} is loaded twice; give each a unique name")

    producers: dict[str, list[PortInfo]] = {}
    consumers: dict[str, list[PortInfo]] = {}
    for node in nodes:
        for p in node.outputs:
            producers.setdefault(p.topic, []).append(p)
        for p in node.inputs:
            consumers.setdefault(p.topic, []).append(p)

    by_name = {n.name: n for n in nodes}
    warnings: list[str] = []
    for topic, prods in sorted(producers.items()):
        if len(prods) > 1:
            _check_producers(topic, prods, consumers.get(topic, []), by_name, warnings)

    edges: list[Edge] = []
    unconnected: list[PortInfo] = []
    for node in nodes:
        for inp in node.inputs:
            found = producers.get(inp.topic)
            if not found:
                unconnected.append(inp)
                continue
            for out in found:  # several: claimed commands, each ordered before the readers
                if not types_compatible(out.type, inp.type):
                    raise GraphError(
                        f"type mismatch on topic {inp.topic!r}: output {out.qualified_name} is "
                        f"{_type_name(out.type)} but input {inp.qualified_name} is "
                        f"{_type_name(inp.type)}; make both ports the same type or remap one"
                    )
                ignored_by = None
                lanes = (by_name[out.component].lane, node.lane)
                if lanes[0] != lanes[1] and (lanes[0] in let_lanes or lanes[1] in let_lanes):
                    ignored_by = "logical execution time"
                elif node.is_first:
                    ignored_by = "is_first"
                elif node.ignore_pattern is not None and node.ignore_pattern.fullmatch(inp.topic):
                    ignored_by = "topics_ignore_for_graph"
                edges.append(Edge(inp.topic, out, inp, ignored_by))

    unconsumed = [p for n in nodes for p in n.outputs if p.topic not in consumers]
    order = kahn_order(
        names,
        ((e.producer.component, e.consumer.component, e.topic) for e in edges if e.orders),
        by_name,
    )
    return Graph(list(nodes), edges, order, unconnected, unconsumed, warnings)


def _check_producers(
    topic: str,
    prods: list[PortInfo],
    readers: list[PortInfo],
    by_name: dict[str, GraphNode],
    warnings: list[str],
) -> None:
    """Several outputs write ``topic``: claimed commands of one lane (one active at a time,
    :mod:`rtcf._core._claims`) with their readers in that lane, or an error when someone
    reads it (else a warning)."""
    who = ", ".join(p.qualified_name for p in prods)
    plain = [p.qualified_name for p in prods if not p.claimed]
    if not plain:
        lanes = sorted({by_name[p.component].lane for p in (*prods, *readers)})
        if len(lanes) > 1:
            raise GraphError(
                f"topic {topic!r} is claimed by {who} and read in lanes {', '.join(lanes)}; "
                "the claimants of a command topic and its readers must run in one lane: "
                "move them to one lane"
            )
        return
    if len(plain) < len(prods):
        raise GraphError(
            f"topic {topic!r} is written by claimed outputs and by the plain output(s) "
            f"{', '.join(plain)} ({who}); a claimed command topic may only have claimed "
            "writers: declare them all with add_output(..., claim=True), or remap the plain one"
        )
    if readers:
        raise GraphError(
            f"topic {topic!r} has {len(prods)} producers ({who}); a topic may have one "
            "producer: remap all but one of these outputs to other topics (or, for commands "
            "that one active controller at a time writes, declare them with "
            "add_output(..., claim=True))"
        )
    warnings.append(
        f"topic {topic!r} is written by {len(prods)} outputs ({who}) and read by none; "
        "the values are lost: remap the outputs to distinct topics"
    )


def kahn_order(
    names: Sequence[str],
    edges: Iterable[tuple[str, str, str]],
    nodes: dict[str, GraphNode] | None = None,
) -> list[str]:
    """Topological order of ``names`` under ``edges`` (producer, consumer, topic).

    Ties go to the smallest name. A self-edge (a component reading its own output)
    is a cycle too. Raises GraphError naming a cycle if there is one.
    """
    preds: dict[str, dict[str, str]] = {n: {} for n in names}
    succs: dict[str, set[str]] = {n: set() for n in names}
    for src, dst, topic in edges:
        preds[dst].setdefault(src, topic)
        succs[src].add(dst)
    missing = {n: len(p) for n, p in preds.items()}
    ready = [n for n, k in missing.items() if k == 0]
    heapq.heapify(ready)
    order: list[str] = []
    while ready:
        n = heapq.heappop(ready)
        order.append(n)
        for m in succs[n]:
            missing[m] -= 1
            if missing[m] == 0:
                heapq.heappush(ready, m)
    if len(order) != len(names):
        left = sorted(n for n in names if missing[n] > 0)
        raise GraphError(_describe_cycle(_find_cycle(left, preds), nodes))
    return order


def _find_cycle(left: list[str], preds: dict[str, dict[str, str]]) -> list[tuple[str, str]]:
    """Return one cycle among ``left`` as [(component, topic it writes to the next), ...]."""
    remaining = set(left)
    node = left[0]
    path: list[str] = []
    seen: dict[str, int] = {}
    while node not in seen:
        seen[node] = len(path)
        path.append(node)
        node = min(p for p in preds[node] if p in remaining)
    cycle = path[seen[node] :]
    cycle.reverse()  # we walked backwards along predecessors
    return [(c, preds[cycle[(i + 1) % len(cycle)]][c]) for i, c in enumerate(cycle)]


def _describe_cycle(cycle: list[tuple[str, str]], nodes: dict[str, GraphNode] | None) -> str:
    start = min(range(len(cycle)), key=lambda i: cycle[i][0])
    cycle = cycle[start:] + cycle[:start]
    chain = " ".join(f"{c} -[{t}]->" for c, t in cycle) + f" {cycle[0][0]}"
    first, first_topic_in = cycle[0][0], cycle[-1][1]
    return (
        f"cycle in the data flow: {chain}; break it with is_first on one of these components "
        f"(e.g. is_first on {first}), or with topics_ignore_for_graph on a consumer "
        f"(e.g. topics_ignore_for_graph: '{re.escape(first_topic_in)}' on {first})"
    )


def _type_name(t: type[Any]) -> str:
    mod = getattr(t, "__module__", "")
    return t.__qualname__ if mod in ("builtins", "") else f"{mod}.{t.__qualname__}"


def to_dot(graph: Graph) -> str:
    """Graphviz DOT: components as boxes, connections labelled with their topic;
    edges left out of the ordering are dashed. With lanes, each lane is a cluster and
    the edges that cross lanes are bold."""
    rank = {n: i for i, n in enumerate(graph.order)}
    lines = ["digraph rtcf {", "  rankdir=LR;", '  node [shape=box, fontname="Helvetica"];']
    lanes = _lanes(graph)
    for lane, nodes in lanes.items():
        indent = "  "
        if len(lanes) > 1:
            lines += [f'  subgraph "cluster_{lane}" {{', f'    label="lane {lane}";']
            indent = "    "
        for node in sorted(nodes, key=lambda n: rank.get(n.name, 0)):
            label = f"{node.name}\\n{node.label} (#{rank[node.name] + 1})"
            if node.is_first:
                label += "\\nis_first"
            lines.append(f'{indent}"{node.name}" [label="{label}"];')
        if len(lanes) > 1:
            lines.append("  }")
    lane_of = {n.name: n.lane for n in graph.nodes}
    for e in graph.edges:
        style = ", style=dashed, constraint=false" if not e.orders else ""
        if lane_of.get(e.producer.component) != lane_of.get(e.consumer.component):
            style += ", penwidth=2"
        lines.append(
            f'  "{e.producer.component}" -> "{e.consumer.component}" [label="{e.topic}"{style}];'
        )
    lines.append("}")
    return "\n".join(lines) + "\n"


def _lanes(graph: Graph) -> dict[str, list[GraphNode]]:
    """The nodes by lane, the main lane first."""
    out: dict[str, list[GraphNode]] = {}
    for node in sorted(graph.nodes, key=lambda n: (n.lane != "main", n.lane)):
        out.setdefault(node.lane, []).append(node)
    return out


def to_mermaid(graph: Graph) -> str:
    """Mermaid flowchart; edges left out of the ordering are dotted."""
    ids = {n.name: f"c{i}" for i, n in enumerate(graph.nodes)}
    rank = {n: i for i, n in enumerate(graph.order)}
    lines = ["flowchart LR"]
    lanes = _lanes(graph)
    for lane, nodes in lanes.items():
        indent = "  "
        if len(lanes) > 1:
            lines.append(f'  subgraph lane_{lane}["lane {lane}"]')
            indent = "    "
        for node in (n for n in graph.nodes if n in nodes):
            extra = " is_first" if node.is_first else ""
            lines.append(
                f'{indent}{ids[node.name]}["{node.name}<br/>{node.label} '
                f'#{rank[node.name] + 1}{extra}"]'
            )
        if len(lanes) > 1:
            lines.append("  end")
    for e in graph.edges:
        arrow = "-.->" if not e.orders else "-->"
        lines.append(
            f'  {ids[e.producer.component]} {arrow}|"{e.topic}"| {ids[e.consumer.component]}'
        )
    return "\n".join(lines) + "\n"
