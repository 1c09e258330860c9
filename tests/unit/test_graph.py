"""The data-flow graph: connections, checks, ordering and drawing."""

from __future__ import annotations

import re

import pytest

from rtcf import GraphError
from rtcf._core._graph import (
    GraphNode,
    PortInfo,
    build_graph,
    kahn_order,
    to_dot,
    to_mermaid,
    types_compatible,
)


def node(
    name: str,
    inputs: dict[str, type] | None = None,
    outputs: dict[str, type] | None = None,
    *,
    is_first: bool = False,
    ignore: str | None = None,
) -> GraphNode:
    """A node whose port on topic ``/t`` is named ``t``."""
    def ports(d: dict[str, type] | None) -> list[PortInfo]:
        return [PortInfo(name, t.strip("/"), t, ty) for t, ty in (d or {}).items()]

    return GraphNode(
        name,
        ports(inputs),
        ports(outputs),
        is_first=is_first,
        ignore_pattern=re.compile(ignore) if ignore else None,
        label="Cls",
    )


class Base:
    pass


class Derived(Base):
    pass


def test_ports_connect_by_topic() -> None:
    g = build_graph([
        node("/src", outputs={"/x": float, "/unused": int}),
        node("/dst", inputs={"/x": float, "/dangling": str}),
    ])
    assert [(e.topic, e.producer.qualified_name, e.consumer.qualified_name) for e in g.edges] == [
        ("/x", "/src.x", "/dst.x")
    ]
    assert g.edges[0].orders and g.edges[0].ignored_by is None
    assert [p.qualified_name for p in g.unconnected_inputs] == ["/dst.dangling"]
    assert [p.qualified_name for p in g.unconsumed_outputs] == ["/src.unused"]
    assert g.order == ["/src", "/dst"]
    assert g.topics() == ["/dangling", "/unused", "/x"]
    assert g.warnings == []


def test_one_output_feeds_several_inputs() -> None:
    g = build_graph([
        node("/c", inputs={"/x": float}),
        node("/b", inputs={"/x": float}),
        node("/z", outputs={"/x": float}),
    ])
    assert sorted(e.consumer.component for e in g.edges) == ["/b", "/c"]
    assert g.order == ["/z", "/b", "/c"]


def test_type_mismatch_names_both_ports_and_topic() -> None:
    with pytest.raises(GraphError) as info:
        build_graph([node("/a", outputs={"/x": int}), node("/b", inputs={"/x": float})])
    msg = str(info.value)
    assert "'/x'" in msg
    assert "output /a.x is int" in msg
    assert "input /b.x is float" in msg


def test_type_mismatch_names_qualified_user_types() -> None:
    with pytest.raises(GraphError, match=r"output /a\.x is .*test_graph\.Base but input /b\.x is "
                                         r".*test_graph\.Derived"):
        build_graph([node("/a", outputs={"/x": Base}), node("/b", inputs={"/x": Derived})])


def test_subclass_and_object_inputs_are_compatible() -> None:
    assert types_compatible(Derived, Base)
    assert types_compatible(int, object)
    assert types_compatible(float, float)
    assert not types_compatible(Base, Derived)
    assert not types_compatible(int, float)
    assert not types_compatible(bool, float)
    assert types_compatible(bool, int)
    g = build_graph([
        node("/a", outputs={"/x": Derived, "/y": int}),
        node("/b", inputs={"/x": Base, "/y": object}),
    ])
    assert len(g.edges) == 2


def test_two_producers_on_a_consumed_topic_is_an_error_naming_both() -> None:
    with pytest.raises(GraphError) as info:
        build_graph([
            node("/p1", outputs={"/x": float}),
            node("/p2", outputs={"/x": float}),
            node("/c", inputs={"/x": float}),
        ])
    msg = str(info.value)
    assert "'/x'" in msg and "2 producers" in msg
    assert "/p1.x" in msg and "/p2.x" in msg
    assert "remap" in msg


def test_two_producers_on_an_unconsumed_topic_is_a_warning() -> None:
    g = build_graph([node("/p1", outputs={"/x": float}), node("/p2", outputs={"/x": int})])
    assert len(g.warnings) == 1
    w = g.warnings[0]
    assert "'/x'" in w and "/p1.x" in w and "/p2.x" in w and "read by none" in w
    assert g.edges == []


def test_component_loaded_twice_is_an_error() -> None:
    with pytest.raises(GraphError, match="'/a' is loaded twice"):
        build_graph([node("/a"), node("/a")])


CHAIN = [
    ("/c", {"/y": float}, {"/z": float}),
    ("/a", {}, {"/x": float}),
    ("/b", {"/x": float}, {"/y": float}),
    ("/m", {}, {}),
    ("/d", {"/z": float, "/x": float}, {}),
]


@pytest.mark.parametrize("rotation", range(len(CHAIN)))
def test_kahn_order_is_independent_of_input_order(rotation: int) -> None:
    specs = CHAIN[rotation:] + CHAIN[:rotation]
    g = build_graph([node(n, i, o) for n, i, o in specs])
    # /a and /m are ready first and /a wins; then /b, /c and /d each sort before
    # /m when they become ready
    assert g.order == ["/a", "/b", "/c", "/d", "/m"]
    assert build_graph([node(n, i, o) for n, i, o in reversed(specs)]).order == g.order


def test_tie_break_uses_plain_string_order() -> None:
    assert kahn_order(["/b", "/B", "/a", "/_"], []) == ["/B", "/_", "/a", "/b"]


def test_kahn_order_with_diamond() -> None:
    edges = [("/s", "/l", "t1"), ("/s", "/r", "t2"), ("/l", "/j", "t3"), ("/r", "/j", "t4")]
    assert kahn_order(["/j", "/r", "/l", "/s"], edges) == ["/s", "/l", "/r", "/j"]


def test_is_first_drops_incoming_edges_from_ordering_but_keeps_them_listed() -> None:
    g = build_graph([
        node("/a", inputs={"/back": float}, outputs={"/fwd": float}, is_first=True),
        node("/b", inputs={"/fwd": float}, outputs={"/back": float}),
    ])
    by_topic = {e.topic: e for e in g.edges}
    assert by_topic["/back"].ignored_by == "is_first"
    assert not by_topic["/back"].orders
    assert by_topic["/fwd"].ignored_by is None
    assert g.order == ["/a", "/b"]


def test_is_first_on_the_name_that_sorts_last_reverses_the_order() -> None:
    g = build_graph([
        node("/a", inputs={"/fwd": float}, outputs={"/back": float}),
        node("/z", inputs={"/back": float}, outputs={"/fwd": float}, is_first=True),
    ])
    assert g.order == ["/z", "/a"]


def test_topics_ignore_for_graph_full_match() -> None:
    g = build_graph([
        node("/a", inputs={"/fb/y": float, "/fb/y2": float}, outputs={"/u": float},
             ignore="/fb/y"),
        node("/b", inputs={"/u": float}, outputs={"/fb/y": float}),
        node("/c", outputs={"/fb/y2": float}),
    ])
    by_topic = {e.topic: e for e in g.edges}
    assert by_topic["/fb/y"].ignored_by == "topics_ignore_for_graph"
    # "/fb/y" does not fully match "/fb/y2": that edge still orders
    assert by_topic["/fb/y2"].ignored_by is None
    assert g.order == ["/c", "/a", "/b"]


def test_cycle_error_names_components_topics_and_remedies() -> None:
    with pytest.raises(GraphError) as info:
        build_graph([
            node("/ctrl", inputs={"/y": float}, outputs={"/u": float}),
            node("/plant", inputs={"/u": float}, outputs={"/y": float}),
            node("/free"),
        ])
    msg = str(info.value)
    assert msg.startswith("cycle in the data flow: ")
    assert "/ctrl -[/u]" in msg and "/plant -[/y]" in msg
    assert "/free" not in msg
    assert "is_first" in msg and "topics_ignore_for_graph" in msg
    assert "is_first on /ctrl" in msg
    assert "topics_ignore_for_graph: '/y' on /ctrl" in msg


def test_cycle_error_shows_only_the_cycle_not_its_downstream() -> None:
    with pytest.raises(GraphError) as info:
        build_graph([
            node("/b", inputs={"/y": float}, outputs={"/x": float}),
            node("/c", inputs={"/x": float}, outputs={"/y": float}),
            node("/a", outputs={"/s": float}),
            node("/d", inputs={"/x": float, "/s": float}),
        ])
    msg = str(info.value)
    assert "/b -[/x]" in msg and "/c -[/y]" in msg
    assert "/d" not in msg and "/a" not in msg


def test_self_loop_is_a_cycle() -> None:
    with pytest.raises(GraphError) as info:
        build_graph([node("/s", inputs={"/x": float}, outputs={"/x": float})])
    msg = str(info.value)
    assert "/s -[/x]" in msg and "is_first on /s" in msg
    # ... which is_first breaks
    g = build_graph([node("/s", inputs={"/x": float}, outputs={"/x": float}, is_first=True)])
    assert g.order == ["/s"]
    assert g.edges[0].ignored_by == "is_first"


def _drawn_graph():
    return build_graph([
        node("/a", inputs={"/back": float}, outputs={"/fwd": float}, is_first=True),
        node("/b", inputs={"/fwd": float}, outputs={"/back": float, "/side": int}),
        node("/c", inputs={"/side": int}),
    ])


def test_dot_contains_every_edge_and_dashes_ignored_ones() -> None:
    dot = to_dot(_drawn_graph())
    assert dot.startswith("digraph rtcf {") and dot.rstrip().endswith("}")
    assert '"/a" -> "/b" [label="/fwd"];' in dot
    assert '"/b" -> "/c" [label="/side"];' in dot
    assert '"/b" -> "/a" [label="/back", style=dashed, constraint=false];' in dot
    assert dot.count("->") == 3
    assert dot.count("dashed") == 1
    assert "is_first" in dot
    assert "(#1)" in dot and "(#3)" in dot


def test_mermaid_contains_every_edge_and_dots_ignored_ones() -> None:
    mm = to_mermaid(_drawn_graph())
    lines = mm.splitlines()
    assert lines[0] == "flowchart LR"
    ids = {}
    for line in lines[1:]:
        m = re.match(r'\s+(c\d+)\["(/\w+)<br/>', line)
        if m:
            ids[m.group(2)] = m.group(1)
    assert set(ids) == {"/a", "/b", "/c"}
    assert f'{ids["/a"]} -->|"/fwd"| {ids["/b"]}' in mm
    assert f'{ids["/b"]} -->|"/side"| {ids["/c"]}' in mm
    assert f'{ids["/b"]} -.->|"/back"| {ids["/a"]}' in mm
    assert mm.count("-.->") == 1
    assert mm.count("-->") == 2


def _laned_graph():
    a = node("/a", outputs={"/x": float})
    b = node("/b", inputs={"/x": float}, outputs={"/y": float})
    c = node("/c", inputs={"/y": float})
    b.lane = "arm"
    return build_graph([a, b, c])


def test_dot_draws_each_lane_as_a_cluster_and_crossing_edges_bold() -> None:
    dot = to_dot(_laned_graph())
    assert 'subgraph "cluster_main" {' in dot and 'subgraph "cluster_arm" {' in dot
    arm = dot.split('subgraph "cluster_arm" {')[1].split("}")[0]
    assert '"/b"' in arm and '"/a"' not in arm
    assert '"/a" -> "/b" [label="/x", penwidth=2];' in dot
    assert '"/b" -> "/c" [label="/y", penwidth=2];' in dot
    assert "cluster" not in to_dot(_drawn_graph())  # one lane: no clusters


def test_mermaid_draws_each_lane_as_a_subgraph() -> None:
    mm = to_mermaid(_laned_graph())
    assert '  subgraph lane_arm["lane arm"]' in mm and '  subgraph lane_main["lane main"]' in mm
    arm = mm.split('subgraph lane_arm["lane arm"]')[1].split("  end")[0]
    assert "/b<br/>" in arm and "/a<br/>" not in arm
