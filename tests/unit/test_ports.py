"""Ports: shared slots, flow status, connection."""

from __future__ import annotations

from rtcf import FlowStatus, InputPort, OutputPort


def _pair() -> tuple[OutputPort[float], InputPort[float]]:
    out: OutputPort[float] = OutputPort("/a", "out", float)
    inp: InputPort[float] = InputPort("/b", "in", float)
    inp._connect(out)
    return out, inp


def test_unconnected_input_has_no_data() -> None:
    inp: InputPort[int] = InputPort("/b", "in", int)
    assert inp.read() is None
    assert inp.status is FlowStatus.NO_DATA
    assert not inp.has_new_data
    assert not inp.connected
    assert inp.producer is None


def test_status_new_then_old() -> None:
    out, inp = _pair()
    assert inp.connected and inp.producer is out
    assert inp.status is FlowStatus.NO_DATA
    out.write(1.0)
    assert inp.status is FlowStatus.NEW_DATA
    assert inp.has_new_data
    assert inp.read() == 1.0
    assert inp.status is FlowStatus.OLD_DATA
    assert not inp.has_new_data
    assert inp.read() == 1.0  # the value stays
    out.write(1.0)  # the same value written again is new data
    assert inp.status is FlowStatus.NEW_DATA


def test_values_are_shared_by_reference() -> None:
    out: OutputPort[list] = OutputPort("/a", "out", list)
    inp: InputPort[list] = InputPort("/b", "in", list)
    inp._connect(out)
    value = [1, 2]
    out.write(value)
    assert inp.read() is value


def test_two_inputs_see_status_independently() -> None:
    out, a = _pair()
    b: InputPort[float] = InputPort("/c", "in", float)
    b._connect(out)
    out.write(3.0)
    a.read()
    assert a.status is FlowStatus.OLD_DATA
    assert b.status is FlowStatus.NEW_DATA
    assert b.read() == 3.0


def test_reconnecting_to_the_same_producer_keeps_seen_state() -> None:
    out, inp = _pair()
    out.write(1.0)
    inp.read()
    inp._connect(out)
    assert inp.status is FlowStatus.OLD_DATA


def test_connecting_to_a_new_producer_resets_seen() -> None:
    out, inp = _pair()
    out.write(1.0)
    inp.read()
    other: OutputPort[float] = OutputPort("/z", "out", float)
    inp._connect(other)
    assert inp.status is FlowStatus.NO_DATA
    other.write(5.0)
    assert inp.status is FlowStatus.NEW_DATA
    assert inp.read() == 5.0


def test_disconnecting_gives_a_fresh_slot() -> None:
    out, inp = _pair()
    out.write(1.0)
    inp._connect(None)
    assert not inp.connected
    assert inp.read() is None
    assert inp.status is FlowStatus.NO_DATA
    out.write(2.0)
    assert inp.read() is None


def test_unconnected_input_keeps_a_bridge_fed_value() -> None:
    inp: InputPort[float] = InputPort("/b", "in", float)
    inp._slot.value = 9.0  # what a middleware bridge does
    inp._slot.seq = 1
    inp._connect(None)
    assert inp.status is FlowStatus.NEW_DATA
    assert inp.read() == 9.0


def test_names_and_repr() -> None:
    out, inp = _pair()
    out.topic = "/t"
    assert out.qualified_name == "/a.out"
    assert inp.qualified_name == "/b.in"
    assert repr(out) == "<OutputPort /a.out -> /t [float]>"
    assert repr(inp) == "<InputPort /b.in <- ? [float]>"
    assert out.direction == "output" and inp.direction == "input"
