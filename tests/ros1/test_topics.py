"""Ports mapped to ROS 1 topics, end to end through a real roscore."""

import subprocess
import sys

import numpy as np
import pytest
import rosgraph
from std_msgs.msg import Bool, ColorRGBA, Float64, Float64MultiArray, Int64, String

from ._helpers import stop, wait_running, wait_until
from .conftest import rtcf_env, start_runner

pytestmark = pytest.mark.integration

WHITELIST = "/ros/.*"


def component(name, cls, remaps, **params):
    return {
        "name": name,
        "module": "rtcf_ros1_components",
        "class": cls,
        "remaps": remaps,
        "params": params,
    }


def test_a_float_comes_back_transformed_and_rostopic_sees_the_types(topics):
    got = topics.sub("/ros/out", Float64)
    pub = topics.pub("/ros/in", Float64)
    proc = start_runner(
        [component("scale", "Scale", {"in": "/ros/in", "out": "/ros/out"}, gain=3.0)],
        ros_mapping_whitelist=WHITELIST,
    )
    try:
        wait_running(proc)
        for value in (-10.0, 0.0, 1234.56):
            got.clear()
            assert wait_until(
                lambda v=value: bool(got) and got[-1].data == pytest.approx(3 * v),
                publish=lambda v=value: pub.publish(Float64(data=v)),
            ), f"no {3 * value} on /ros/out (last: {got[-3:]})"
        master = rosgraph.Master("/rtcf_test_check")
        types = dict(master.getTopicTypes())
        assert types["/ros/out"] == "std_msgs/Float64"
        assert types["/ros/in"] == "std_msgs/Float64"  # the raw subscription's real type
        pubs, subs, _ = master.getSystemState()
        assert "/rt_runner" in dict(pubs)["/ros/out"]
        assert "/rt_runner" in dict(subs)["/ros/in"]
        # rostopic knows the type from the master and deserializes what the runner sent
        echo = subprocess.Popen(
            ["rostopic", "echo", "-n", "1", "/ros/out"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            env=rtcf_env(),
        )
        wait_until(lambda: echo.poll() is not None, publish=lambda: pub.publish(Float64(data=1.5)))
        out, err = echo.communicate(timeout=10)
        assert "data: 4.5" in out, (out, err)
    finally:
        if proc.poll() is None:
            stop(proc)


def test_genpy_message_ports_cross_as_serialized_bytes(topics):
    got = topics.sub("/ros/y", Float64)
    pub = topics.pub("/ros/x", Float64)
    proc = start_runner(
        [
            component("a", "ScaleMsg", {"in": "/ros/x", "out": "/mid"}, gain=2.0),
            component("b", "ScaleMsg", {"in": "/mid", "out": "/ros/y"}, gain=5.0),
        ],
        ros_mapping_whitelist=WHITELIST,
    )
    try:
        wait_running(proc)
        assert wait_until(
            lambda: bool(got) and got[-1].data == pytest.approx(10 * 1.5),
            publish=lambda: pub.publish(Float64(data=1.5)),
        ), got[-3:]
        assert "/mid" not in dict(rosgraph.Master("/rtcf_test_check").getTopicTypes())
    finally:
        if proc.poll() is None:
            _, err = stop(proc)
            assert "error" not in err.lower(), err


def test_every_port_kind_round_trips(topics):
    remaps = {}
    for port in ("int", "bool", "str", "array", "color"):
        remaps[f"{port}_in"] = f"/ros/{port}_in"
        remaps[f"{port}_out"] = f"/ros/{port}_out"
    sent = {
        "int": (Int64, Int64(data=-(2**40)), lambda m: m.data == -(2**40) + 1),
        "bool": (Bool, Bool(data=False), lambda m: m.data is True),
        "str": (String, String(data="grüß dich"), lambda m: m.data == "GRÜSS DICH"),
        "array": (
            Float64MultiArray,
            Float64MultiArray(data=[1.0, -2.5, 1e300]),
            lambda m: list(m.data) == [2.0, -5.0, 2e300],
        ),
        "color": (
            ColorRGBA,
            ColorRGBA(r=0.25, g=0.5, b=0.75, a=1.0),
            lambda m: (m.r, m.g, m.b, m.a) == (0.75, 0.5, 0.25, 1.0),
        ),
    }
    got = {k: topics.sub(f"/ros/{k}_out", cls) for k, (cls, _, _) in sent.items()}
    pubs = {k: topics.pub(f"/ros/{k}_in", cls) for k, (cls, _, _) in sent.items()}
    proc = start_runner(
        [component("kinds", "Kinds", remaps)], ros_mapping_whitelist=WHITELIST
    )
    try:
        wait_running(proc)
        types = dict(rosgraph.Master("/rtcf_test_check").getTopicTypes())
        assert types["/ros/array_out"] == "std_msgs/Float64MultiArray"
        assert types["/ros/color_out"] == "std_msgs/ColorRGBA"

        def publish_all():
            for k, (_, msg, _) in sent.items():
                pubs[k].publish(msg)

        def all_back():
            return all(got[k] and check(got[k][-1]) for k, (_, _, check) in sent.items())

        assert wait_until(all_back, publish=publish_all), {k: v[-1:] for k, v in got.items()}
        # a Float64MultiArray with a layout of its own: the data still arrive
        with_dims = Float64MultiArray(data=[3.0, 4.0])
        with_dims.layout.dim = [_dim("x", 2, 2)]
        with_dims.layout.data_offset = 0
        assert wait_until(
            lambda: list(got["array"][-1].data) == [6.0, 8.0],
            publish=lambda: pubs["array"].publish(with_dims),
        )
    finally:
        if proc.poll() is None:
            _, err = stop(proc)
            assert "error" not in err.lower(), err


def _dim(label, size, stride):
    from std_msgs.msg import MultiArrayDimension

    return MultiArrayDimension(label=label, size=size, stride=stride)


def test_the_runner_node_is_named_after_the_runner_in_its_namespace(topics):
    got = topics.sub("/ros/out2", Float64)
    pub = topics.pub("/ros/in2", Float64)
    proc = start_runner(
        [component("scale", "Scale", {"in": "/ros/in2", "out": "/ros/out2"}, gain=-1.0)],
        name="arm_runner",
        namespace="/robot",
        ros_mapping_whitelist=WHITELIST,
    )
    try:
        err = wait_running(proc)
        assert "node /robot/arm_runner" in err
        assert wait_until(
            lambda: bool(got) and got[-1].data == -2.0,
            publish=lambda: pub.publish(Float64(data=2.0)),
        )
        pubs, _, _ = rosgraph.Master("/rtcf_test_check").getSystemState()
        assert dict(pubs)["/ros/out2"] == ["/robot/arm_runner"]
    finally:
        if proc.poll() is None:
            stop(proc)


def test_plain_kinds_serialize_as_genpy_does():
    """The hand-made ROS 1 bytes of the plain kinds are genpy's, bit for bit."""
    from io import BytesIO

    from rtcf._ros1._bridge import from_wire, to_wire
    from rtcf._runtime._codec import codec_for

    def genpy_bytes(msg):
        buf = BytesIO()
        msg.serialize(buf)
        return buf.getvalue()

    cases = [
        (float, Float64, -1.25e-300, lambda v: Float64(data=v)),
        (int, Int64, -(2**62), lambda v: Int64(data=v)),
        (bool, Bool, True, lambda v: Bool(data=v)),
        (str, String, "µ-ok", lambda v: String(data=v)),
        (np.ndarray, Float64MultiArray, np.array([0.5, -1.0]), lambda v: Float64MultiArray(
            data=list(v))),
    ]
    for py, ros, value, make in cases:
        codec = codec_for(py)
        wire = to_wire(codec.kind, codec.encode(value))
        assert wire == genpy_bytes(make(value)), py
        back = codec.decode(from_wire(codec.kind, ros, wire))
        assert np.array_equal(back, value) if py is np.ndarray else back == value
    assert from_wire("float", Float64, b"\x00" * 7) is None
    assert from_wire("str", String, b"\x05\x00\x00\x00ab") is None


def test_no_master_is_a_clear_error():
    env = rtcf_env()
    env["ROS_MASTER_URI"] = "http://127.0.0.1:1"  # nothing listens there
    code = (
        "from rtcf._ros1._bridge import Ros1Bridge\n"
        "from rtcf._core._errors import RtcfError\n"
        "try:\n"
        "    Ros1Bridge('r')\n"
        "except RtcfError as exc:\n"
        "    print(exc)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=30
    )
    assert out.stdout.strip() == (
        "no ROS master answers at http://127.0.0.1:1; start roscore or set ROS_MASTER_URI"
    ), out
