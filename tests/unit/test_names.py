"""ROS graph-name rules: validation, expansion, remapping."""

from __future__ import annotations

import pytest

from rtcf._core._names import (
    Resolver,
    basename,
    expand,
    join,
    namespace_of,
    normalize_namespace,
    validate_name,
)


@pytest.mark.parametrize(
    "name",
    ["a", "_a", "a1/b_2", "/abs/name", "~private", "~/private", "~", "/", "A/B/c9"],
)
def test_valid_names(name: str) -> None:
    assert validate_name(name) is None


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("", "is empty"),
        ("a/", "ends with '/'"),
        ("/a/b/", "ends with '/'"),
        ("a//b", "contains '//'"),
        ("1abc", "must start with a letter"),
        ("a/2b", "must start with a letter"),
        ("a-b", "must start with a letter"),
        ("a b", "must start with a letter"),
        ("~a/", "ends with '/'"),
    ],
)
def test_invalid_names(name: str, fragment: str) -> None:
    problem = validate_name(name, what="topic")
    assert problem is not None
    assert fragment in problem
    assert problem.startswith("topic")


def test_validate_names_the_name_in_the_message() -> None:
    problem = validate_name("x//y", what="port name")
    assert problem == "port name 'x//y' contains '//'"


@pytest.mark.parametrize(
    ("ns", "expected"),
    [
        (None, "/"),
        ("", "/"),
        ("/", "/"),
        ("a", "/a"),
        ("/a/", "/a"),
        ("//a///b//", "/a/b"),
        ("a/b", "/a/b"),
    ],
)
def test_normalize_namespace(ns: str | None, expected: str) -> None:
    assert normalize_namespace(ns) == expected


def test_join() -> None:
    assert join("/", "x") == "/x"
    assert join("/ns", "x") == "/ns/x"
    assert join("ns/", "x/y") == "/ns/x/y"
    assert join("/ns", "") == "/ns"
    assert join("", "") == "/"


@pytest.mark.parametrize(
    ("name", "ns", "node", "expected"),
    [
        ("/abs", "/ns", "node", "/abs"),
        ("/abs/", "/ns", "node", "/abs"),
        ("rel", "/ns", "node", "/ns/rel"),
        ("rel/sub", "/", "node", "/rel/sub"),
        ("~priv", "/ns", "node", "/ns/node/priv"),
        ("~/priv", "/ns", "node", "/ns/node/priv"),
        ("~", "/ns", "node", "/ns/node"),
        ("~priv", "/", "node", "/node/priv"),
        ("rel", "/a/b", "n", "/a/b/rel"),
    ],
)
def test_expand(name: str, ns: str, node: str, expected: str) -> None:
    assert expand(name, ns, node) == expected


def test_expand_private_without_node_is_an_error() -> None:
    with pytest.raises(ValueError, match="'~x' needs a node"):
        expand("~x", "/ns")


def test_namespace_of_and_basename() -> None:
    assert namespace_of("/a/b/c") == "/a/b"
    assert namespace_of("/a") == "/"
    assert namespace_of("/") == "/"
    assert basename("/a/b/c") == "c"
    assert basename("/a/b/c/") == "c"
    assert basename("c") == "c"


def test_resolver_expands_against_its_namespace() -> None:
    r = Resolver("ns", "node")
    assert r.namespace == "/ns"
    assert r.resolve("x") == "/ns/x"
    assert r.resolve("/x") == "/x"
    assert r.resolve("~x") == "/ns/node/x"
    assert r.private() == "/ns/node"
    assert r.private("gain") == "/ns/node/gain"


def test_resolver_remaps_after_expansion() -> None:
    # "in" relative to /ns is /ns/in; the rule names it absolutely
    r = Resolver("/ns", "node", [("/ns/in", "/other"), ("out", "~priv_out")])
    assert r.resolve("in") == "/other"
    assert r.resolve("/ns/in") == "/other"
    assert r.resolve("out") == "/ns/node/priv_out"
    assert r.resolve("unrelated") == "/ns/unrelated"
    assert r.remaps == {"/ns/in": "/other", "/ns/out": "/ns/node/priv_out"}


def test_resolver_remap_target_is_not_remapped_again() -> None:
    r = Resolver("/", "n", [("a", "b"), ("b", "c")])
    assert r.resolve("a") == "/b"
    assert r.resolve("b") == "/c"


def test_resolver_last_rule_wins() -> None:
    r = Resolver("/", "n", [("x", "first"), ("/x", "second")])
    assert r.resolve("x") == "/second"


def test_resolver_accepts_a_mapping_and_copies_remaps() -> None:
    r = Resolver("/ns", "n", {"x": "/y"})
    assert r.resolve("x") == "/y"
    copy = r.remaps
    copy["/ns/x"] = "/changed"
    assert r.resolve("x") == "/y"
