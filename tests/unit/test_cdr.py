"""rtcf.Serialized without ROS: the layout of plain-Python message classes, byte for byte.

Any class with ``get_fields_and_field_types()`` in the rosidl form is a message here
(nested types found as ``pkg.msg.Type``, like rosidl's), so the core's layout is
checked on the Pythons that have no ROS 2; tests/ros2/test_cdr.py checks it against
rclpy's serializer.
"""

from __future__ import annotations

import struct
import sys
import types
from typing import Any

import numpy as np
import pytest

import rtcf
from rtcf import Serialized
from rtcf._core._cdr import example_fields
from rtcf._core._lanes import LocalLet
from rtcf._core._loop_state import LoopState
from rtcf._core._ports import Slot


def _message(name: str, fields: dict[str, str]) -> type:
    def init(self: Any, **kw: Any) -> None:
        for f in fields:
            setattr(self, f, kw.get(f))

    def eq(self: Any, other: Any) -> bool:
        return type(other) is type(self) and all(
            getattr(self, f) == getattr(other, f) for f in fields
        )

    return type(name, (), {
        "get_fields_and_field_types": classmethod(lambda cls: dict(fields)),
        "__init__": init, "__eq__": eq, "__module__": "cdrfake.msg",
    })


@pytest.fixture
def msgs(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    mod = types.ModuleType("cdrfake.msg")
    mod.Time = _message("Time", {"sec": "int32", "nanosec": "uint32"})
    mod.Header = _message("Header", {"stamp": "cdrfake/Time", "frame_id": "string"})
    mod.Item = _message("Item", {"key": "string<=4", "x": "float"})
    mod.State = _message("State", {
        "header": "cdrfake/Header", "name": "sequence<string>",
        "position": "sequence<double>", "small": "int16", "big": "uint64",
        "flags": "boolean[3]",
    })
    mod.Bag = _message("Bag", {"items": "sequence<cdrfake/Item, 3>", "xyz": "double[3]",
                               "point": "cdrfake/Point"})
    mod.Point = _message("Point", {"x": "double", "y": "double", "z": "double"})
    monkeypatch.setitem(sys.modules, "cdrfake", types.ModuleType("cdrfake"))
    monkeypatch.setitem(sys.modules, "cdrfake.msg", mod)
    return mod


def test_the_bytes_by_hand(msgs: types.ModuleType) -> None:
    s = Serialized(msgs.State, name=["x"], position=[1.5], small=-2, big=7,
                   flags=[True, False, True], header={"frame_id": "ab"})
    s.stamp_ns = 1_000_000_002
    expected = b"".join([
        b"\x00\x01\x00\x00",  # the header; offsets below count from after it
        struct.pack("<iI", 1, 2),  # 0: stamp
        struct.pack("<I", 3), b"ab\x00", b"\x00",  # 8: frame_id, padding to 16
        struct.pack("<II", 1, 2), b"x\x00", b"\x00\x00",  # 16: name, padding to 28
        struct.pack("<I", 1), struct.pack("<d", 1.5),  # 28: count, 32: 8-aligned already
        struct.pack("<h", -2), b"\x00" * 6,  # 40: small, padding to 48
        struct.pack("<Q", 7),  # 48: big
        b"\x01\x00\x01",  # 56: flags, no count (an array)
    ])
    assert bytes(s) == expected
    assert s.stamp_ns == 1_000_000_002
    assert s.small == -2 and s.big == 7 and s.name == ("x",)
    assert s.header.frame_id == "ab" and s.header.stamp.nanosec == 2


def test_views_write_into_the_bytes(msgs: types.ModuleType) -> None:
    s = Serialized(msgs.State, position=3)
    s.position[:] = (1.0, 2.0, 3.0)
    s.view("small")[0] = 5
    s.big = 9
    msg = s.to_message()
    assert msg.position == [1.0, 2.0, 3.0] and msg.small == 5 and msg.big == 9
    assert msg.header.stamp.sec == 0 and msg.name == [] and msg.flags == [False] * 3
    with pytest.raises(AttributeError, match="only numbers"):
        s.name = ["y"]
    with pytest.raises(ValueError):
        s.position = (1.0, 2.0)  # the length is fixed


def test_nested_sequences_arrays_and_packed_messages(msgs: types.ModuleType) -> None:
    s = Serialized(msgs.Bag, items=[{"key": "ab", "x": 1.0}, msgs.Item(key="c", x=2.0)])
    s.view("items[1].x")[0] = 4.0
    s.view("point")[:] = (1.0, 2.0, 3.0)  # Point: three doubles back to back
    s.xyz[:] = (7.0, 8.0, 9.0)
    assert [i.x for i in s.items] == [1.0, 4.0] and s.items[0].key == "ab"
    assert s.point.z == 3.0
    msg = s.to_message()
    assert msg.point.y == 2.0 and msg.xyz == [7.0, 8.0, 9.0]
    with pytest.raises(ValueError, match="at most 3"):
        Serialized(msgs.Bag, items=4)
    with pytest.raises(ValueError, match="not a string of this field"):
        Serialized(msgs.Bag, items=[{"key": "abcde"}])  # string<=4
    with pytest.raises(KeyError, match="index out of range"):
        s.view("items[2].x")
    with pytest.raises(AttributeError, match=r"has no header\.stamp"):
        s.stamp_ns = 1


def test_of_a_message_and_the_example_fields(msgs: types.ModuleType) -> None:
    s = Serialized(msgs.Bag, **example_fields(msgs.Bag))
    again = Serialized.of(s.to_message())
    assert bytes(again) == bytes(s) and again.to_message() == s.to_message()
    assert len(s.items) == 2 and all(i.key for i in s.items)


def test_a_let_lane_in_process_gets_the_message_of_its_release(
    msgs: types.ModuleType,
) -> None:
    # the writer rewrites its Serialized in place: the LET lane must see the values it
    # was released with, as lanes in their own processes (which carry the bytes) do
    s = Serialized(msgs.State, position=1)
    topic, private = Slot(), Slot()
    topic.value, topic.seq = s, 1
    state = LoopState(1000.0)
    let = LocalLet(state, [(2, 0, [(topic, private)], [])])
    s.position[0] = 1.0
    state.iteration = 0
    let()  # released: takes its inputs
    s.position[0] = 2.0  # the writer's next write
    assert isinstance(private.value, msgs.State)
    assert private.value.position == [1.0]
    assert np.array_equal(s.position, [2.0])


def test_the_trace_keeps_each_iterations_message(msgs: types.ModuleType) -> None:
    import rtcf
    from rtcf.testing import run_components

    class Writer(rtcf.Component):
        def configure(self) -> None:
            self.out = self.add_output("state", msgs.State)
            self.s = Serialized(msgs.State, position=1)

        def update(self) -> None:
            self.s.position[0] = self.iteration
            self.out.write(self.s)

    trace = run_components([Writer], iterations=3)
    assert [m.position for m in trace.outputs["/state"]] == [[0.0], [1.0], [2.0]]


def test_a_stamp_anywhere(msgs: types.ModuleType) -> None:
    s = Serialized(msgs.State)
    set_stamp = s.stamp_setter("header.stamp")
    set_stamp(3_000_000_004)
    assert (s.header.stamp.sec, s.header.stamp.nanosec) == (3, 4) and s.stamp_ns == 3_000_000_004
    with pytest.raises(ValueError, match="not a builtin_interfaces/Time"):
        s.stamp_setter("header")


def test_an_action_trace_keeps_each_feedbacks_message(msgs: types.ModuleType) -> None:
    from rtcf._core._action_protocol import ActionEndpoint

    fb = Serialized(msgs.State, position=1)
    client = ActionEndpoint("/act")
    for iteration in range(2):  # the writer rewrites the same Serialized each time
        fb.position[:] = iteration
        client.receive(rtcf.ActionEvent(rtcf.ActionEvent.FEEDBACK, 1, 2, fb), iteration)
    kept = client.goals[1].feedback
    assert [(k, type(m), m.position) for k, m in kept] == [
        (0, msgs.State, [0.0]), (1, msgs.State, [1.0])]
