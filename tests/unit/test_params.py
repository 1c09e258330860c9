"""The parameter tree and a component's view of it."""

from __future__ import annotations

import pytest

from rtcf import ConfigurationError, ParameterStore
from rtcf._core._names import Resolver
from rtcf._core._params import Params


def test_set_and_get_leaf() -> None:
    store = ParameterStore()
    store.set("/ns/node/gain", 2.0)
    assert store.get("/ns/node/gain") == 2.0
    assert store.get("ns/node/gain/") == 2.0  # names are normalized
    assert store.names() == ["/ns/node/gain"]


def test_dict_value_sets_leaves_and_namespace_get_assembles_them() -> None:
    store = ParameterStore({"/a": {"b": 1, "c": {"d": "x", "e": [1, 2]}}})
    assert store.names() == ["/a/b", "/a/c/d", "/a/c/e"]
    assert store.get("/a") == {"b": 1, "c": {"d": "x", "e": [1, 2]}}
    assert store.get("/a/c") == {"d": "x", "e": [1, 2]}
    assert store.get("/") == {"a": {"b": 1, "c": {"d": "x", "e": [1, 2]}}}


def test_setting_a_dict_replaces_the_whole_subtree() -> None:
    store = ParameterStore({"/a/old": 1, "/a/keep/x": 2, "/ab": 3})
    store.set("/a", {"new": 4})
    assert store.as_dict() == {"/a/new": 4, "/ab": 3}


def test_setting_a_leaf_over_a_namespace_replaces_it() -> None:
    store = ParameterStore({"/a/b": 1, "/a/c": 2})
    store.set("/a", 5)
    assert store.as_dict() == {"/a": 5}


def test_empty_dict_is_a_leaf() -> None:
    store = ParameterStore()
    store.set("/a", {})
    assert store.get("/a") == {}
    assert store.has("/a")


def test_missing_get_raises_key_error_or_returns_default() -> None:
    store = ParameterStore({"/ab": 1})
    with pytest.raises(KeyError):
        store.get("/a")  # "/ab" is not under "/a"
    assert store.get("/a", None) is None
    assert store.get("/a", 7) == 7


def test_has_and_delete() -> None:
    store = ParameterStore({"/a/b": 1, "/a/c": 2, "/ab": 3})
    assert store.has("/a")
    assert store.has("/a/b")
    assert not store.has("/a/z")
    store.delete("/a")
    assert not store.has("/a")
    assert store.as_dict() == {"/ab": 3}
    assert len(store) == 1


def test_items_are_sorted_and_update_merges() -> None:
    store = ParameterStore({"/z": 1, "/a": 2})
    assert list(store.items()) == [("/a", 2), ("/z", 1)]
    store.update(ParameterStore({"/m": 3, "/z": 9}))
    assert store.as_dict() == {"/a": 2, "/m": 3, "/z": 9}
    assert "ParameterStore(" in repr(store)


def _params(store: ParameterStore, ns: str = "/ns", node: str = "node") -> Params:
    return Params(store, Resolver(ns, node), f"{ns}/{node}")


def test_params_resolve_private_relative_absolute() -> None:
    store = ParameterStore({"/ns/node/gain": 1.5, "/ns/shared": 2, "/glob": 3})
    p = _params(store)
    assert p.resolve("~gain") == "/ns/node/gain"
    assert p.get("~gain") == 1.5
    assert p.get("shared") == 2
    assert p.get("/glob") == 3
    assert p.has("~gain")
    assert not p.has("gain")  # relative: /ns/gain
    assert p.get("~") == {"gain": 1.5}


def test_params_missing_without_default_names_it() -> None:
    p = _params(ParameterStore())
    with pytest.raises(ConfigurationError) as info:
        p.get("~missing")
    msg = str(info.value)
    assert "'/ns/node'" in msg
    assert "'/ns/node/missing'" in msg
    assert "'~missing'" in msg
    assert p.get("~missing", 4) == 4
    assert p.get("~missing", None) is None


def test_params_set_writes_the_shared_store() -> None:
    store = ParameterStore()
    p = _params(store)
    p.set("~x", 1)
    p.set("y", 2)
    assert store.as_dict() == {"/ns/node/x": 1, "/ns/y": 2}
