"""The introspection commands' text, from Runner.introspect() in this process."""

from __future__ import annotations

import pytest

from rtcf import Component, ComponentSpec, RtcfError, Runner, RunnerSettings, SimClock
from rtcf._cli._introspection import render


class Source(Component):
    def configure(self) -> None:
        self.out = self.add_output("x", float)
        self.k = self.params.declare("k", 3, description="steps", min=1, max=9)


class Sink(Component):
    def configure(self) -> None:
        self.inp = self.add_input("x", float)
        self.out = self.add_output("ros/y", float)

    def update(self) -> None:
        pass


def data() -> dict:
    r = Runner(RunnerSettings(ros_mapping_whitelist="/ns/ros/.*"), clock=SimClock())
    r.load(ComponentSpec("sink", Sink, namespace="/ns"))
    r.load(ComponentSpec("source", Source, namespace="/ns", params={"note": "hi"}))
    return r.introspect()


def test_lists_and_order() -> None:
    d = data()
    assert render("component_list", d).splitlines()[0].split() == [
        "/ns/sink", f"{__name__}.Sink"
    ]
    assert render("component_order", d).splitlines() == ["1. /ns/source", "2. /ns/sink"]
    lines = render("connection_list", d).splitlines()
    assert lines == ["/ns/ros/y  builtins.float  ROS", "/ns/x      builtins.float"]


def test_infos() -> None:
    d = data()
    info = render("component_info", d, "ns/source")
    assert "    x -> /ns/x  [builtins.float]" in info
    assert "    note: 'hi'" in info
    assert "    k = 3  (int, 1..9)  steps" in info
    assert info.endswith("log level: info")
    conn = render("connection_info", d, "/ns/x")
    assert conn.splitlines() == [
        "/ns/x  [builtins.float]",
        "  publishers: /ns/source",
        "  subscribers: /ns/sink",
        "  mapped to ROS: no",
    ]


def test_unknown_names_say_what_exists() -> None:
    d = data()
    with pytest.raises(RtcfError, match=r"no component '/ns/x' .*loaded: /ns/sink, /ns/source"):
        render("component_info", d, "/ns/x")
    with pytest.raises(RtcfError, match=r"no connection '/q' .*topics: /ns/ros/y, /ns/x"):
        render("connection_info", d, "q")


def test_a_cycle_is_reported_not_an_order() -> None:
    class Loop(Component):
        def configure(self) -> None:
            self.add_input("a", float)
            self.add_output("b", float)

    r = Runner(RunnerSettings(), clock=SimClock())
    r.load(ComponentSpec("one", Loop))
    r.load(ComponentSpec("two", Loop, remaps={"a": "b", "b": "a"}))
    d = r.introspect()
    assert d["order"] == [] and "cycle" in d["problem"]
    with pytest.raises(RtcfError, match=r"no order: .*cycle"):
        render("component_order", d)


def test_mapping_names_what_is_published_and_subscribed() -> None:
    from rtcf._cli._introspection import mapping

    class Reader(Component):
        def configure(self) -> None:
            self.inp = self.add_input("ros/cmd", int)

    d = data()
    assert mapping(d, "/ns/ros/.*") == "publishes /ns/ros/y (float)"
    r = Runner(RunnerSettings(ros_mapping_whitelist="/ns/ros/.*"), clock=SimClock())
    r.load(ComponentSpec("sink", Sink, namespace="/ns"))
    r.load(ComponentSpec("reader", Reader, namespace="/ns"))
    assert mapping(r.introspect(), "/ns/ros/.*") == (
        "publishes /ns/ros/y (float); subscribes /ns/ros/cmd (int)"
    )  # /ns/x has no producer either, but is not whitelisted


def test_mapping_says_why_nothing_is_mapped() -> None:
    from rtcf._cli._introspection import mapping

    empty = Runner(RunnerSettings(), clock=SimClock())
    empty.load(ComponentSpec("sink", Sink, namespace="/ns"))
    assert mapping(empty.introspect(), "") == (
        "no port is mapped to a topic (ros_mapping_whitelist is empty)"
    )
    r = Runner(RunnerSettings(ros_mapping_whitelist="/other/.*"), clock=SimClock())
    r.load(ComponentSpec("sink", Sink, namespace="/ns"))
    assert mapping(r.introspect(), "/other/.*") == (
        "no port is mapped to a topic "
        "(no topic matches ros_mapping_whitelist '/other/.*' and not the blacklist)"
    )


def test_an_inputs_deadline_and_whether_it_is_past_it_now() -> None:
    from rtcf._core._faults import FailurePolicy

    r = Runner(RunnerSettings(), clock=SimClock())
    policy = FailurePolicy(deadlines=(("x", 0.25),))  # the launch file's
    r.load(ComponentSpec("sink", Sink, namespace="/ns", policy=policy))
    d = r.introspect()
    assert "    x -> /ns/x  [builtins.float]  deadline 0.25 s" in render(
        "component_info", d, "/ns/sink"
    )
    d["past_deadline"] = ["/ns/sink.x"]  # as a supervisor tells it
    assert "    x -> /ns/x  [builtins.float]  deadline 0.25 s  PAST ITS DEADLINE NOW" in render(
        "component_info", d, "/ns/sink"
    )
