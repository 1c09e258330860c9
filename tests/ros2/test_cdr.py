"""rtcf.Serialized against rclpy: the bytes it lays out are the message rclpy reads back,
and rclpy's own bytes but for padding (which rclpy leaves uninitialised).

Random values, written through the views as a loop would, for every alignment a
string's length can leave (names of 1 to 9 characters) and 0, 1 and 7 joints.
"""

import numpy as np
import pytest
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, Header, MultiArrayDimension, MultiArrayLayout

from rtcf import ConfigurationError, Serialized
from rtcf._core._cdr import example_fields
from rtcf._runtime import _codec
from rtcf._runtime._codec import codec_for

RNG = np.random.default_rng(32)


def _agrees(ours: Serialized, expected) -> None:
    """rclpy reads our bytes as ``expected``; rclpy's bytes of it are ours off padding."""
    assert deserialize_message(bytes(ours), type(expected)) == expected
    assert ours.same_but_padding(serialize_message(expected))
    assert ours.to_message() == expected


def _stamp(t_ns: int) -> dict:
    return {"sec": t_ns // 10**9, "nanosec": t_ns % 10**9}


@pytest.mark.parametrize("joints", [0, 1, 7])
@pytest.mark.parametrize("chars", range(1, 10))
def test_joint_state_of_every_padding(joints, chars):
    names = [f"{k}".rjust(chars, "j") for k in range(joints)]
    frame = "f" * chars
    ours = Serialized(JointState, name=names, position=joints, velocity=joints, effort=joints,
                      **{"header.frame_id": frame})
    q, v, e = RNG.normal(size=(3, joints)) * 100
    t = int(RNG.integers(0, 2**31 * 10**9))
    ours.position[:] = q
    ours.velocity[:] = v
    ours.effort[:] = e
    ours.stamp_ns = t
    expected = JointState(name=names, position=q.tolist(), velocity=v.tolist(),
                          effort=e.tolist())
    expected.header.frame_id = frame
    expected.header.stamp.sec, expected.header.stamp.nanosec = divmod(t, 10**9)
    _agrees(ours, expected)
    assert ours.stamp_ns == t
    assert ours.name == tuple(names) and ours.header.frame_id == frame


def test_joint_state_with_some_sequences_empty():
    # an empty sequence of doubles has no alignment before its (absent) elements
    for chars in range(1, 9):
        names = ["n" * chars] * 3
        ours = Serialized(JointState, name=names, velocity=2)
        ours.velocity[:] = (1.5, -2.5)
        _agrees(ours, JointState(name=names, velocity=[1.5, -2.5]))


def test_seven_joints_where_the_plan_measured_them():
    ours = Serialized(JointState, name=[f"joint{k + 1}" for k in range(7)],
                      position=7, velocity=7, effort=7)
    assert len(ours) == 300
    offsets = [np.frombuffer(ours._cdr, np.uint8).ctypes.data]
    for field in (ours.position, ours.velocity, ours.effort):
        offsets.append(field.ctypes.data - offsets[0])
    assert offsets[1:] == [116, 180, 244]


def test_odometry_through_its_views():
    ours = Serialized(Odometry, child_frame_id="base_link", **{"header.frame_id": "odom"})
    p, o, cp, lin, ang, ct = (RNG.normal(size=n) for n in (3, 4, 36, 3, 3, 36))
    ours.view("pose.pose.position")[:] = p
    ours.view("pose.pose.orientation")[:] = o
    ours.view("pose.covariance")[:] = cp
    ours.view("twist.twist.linear")[:] = lin
    ours.twist.twist.angular.x, ours.twist.twist.angular.y = ang[:2]
    ours.view("twist.twist.angular.z")[0] = ang[2]
    ours.view("twist.covariance")[:] = ct
    ours.stamp_ns = 1_700_000_000_123_456_789
    expected = Odometry(child_frame_id="base_link")
    expected.header.frame_id = "odom"
    expected.header.stamp.sec, expected.header.stamp.nanosec = 1_700_000_000, 123_456_789
    pose, twist = expected.pose, expected.twist
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = p
    q = pose.pose.orientation
    q.x, q.y, q.z, q.w = o
    pose.covariance = cp
    twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = lin
    twist.twist.angular.x, twist.twist.angular.y, twist.twist.angular.z = ang
    twist.covariance = ct
    _agrees(ours, expected)
    assert ours.pose.pose.position.y == p[1]


@pytest.mark.parametrize("frame", ["", "b", "base_link", "a/b/c/d"])
def test_twist_stamped(frame):
    ours = Serialized(TwistStamped, header={"frame_id": frame})
    lin, ang = RNG.normal(size=(2, 3))
    ours.view("twist.linear")[:] = lin
    ours.view("twist.angular")[:] = ang
    ours.stamp_ns = 5
    expected = TwistStamped()
    expected.header = Header(frame_id=frame, stamp=expected.header.stamp)
    expected.header.stamp.nanosec = 5
    v = expected.twist
    v.linear.x, v.linear.y, v.linear.z = lin
    v.angular.x, v.angular.y, v.angular.z = ang
    _agrees(ours, expected)


@pytest.mark.parametrize("n", [0, 1, 21])
@pytest.mark.parametrize("label", ["", "q", "joints"])
def test_float64_multi_array(n, label):
    dims = [{"label": label, "size": n, "stride": n}, {"label": label * 2, "size": 1,
                                                       "stride": 1}]
    ours = Serialized(Float64MultiArray, data=n, layout={"dim": dims, "data_offset": 3})
    values = RNG.normal(size=n)
    ours.data[:] = values
    expected = Float64MultiArray(
        layout=MultiArrayLayout(dim=[MultiArrayDimension(**d) for d in dims], data_offset=3),
        data=values.tolist(),
    )
    _agrees(ours, expected)
    assert ours.view("layout.dim[1].size")[0] == 1


def test_of_a_message_and_equal_bytes_for_equal_values():
    msg = JointState(name=["a", "bb"], position=[1.0, 2.0], effort=[3.0, 4.0])
    msg.header.frame_id = "x"
    a, b = Serialized.of(msg), Serialized.of(msg)
    _agrees(a, msg)
    assert bytes(a) == bytes(b)  # padding is zero: a recording holds the same bytes


def test_padding_is_not_compared_but_data_is():
    # 'abcd\0' at 28, padding to 36, position's count at 36, 4 bytes of padding,
    # position[0] at 44 (8-aligned counting from after the 4-byte header)
    ours = Serialized(JointState, name=["abcd"], position=1)
    theirs = bytearray(serialize_message(ours.to_message()))
    assert ours.same_but_padding(bytes(theirs))
    at = ours.position.ctypes.data - np.frombuffer(ours._cdr, np.uint8).ctypes.data
    assert at == 44
    theirs[at - 4] ^= 0xFF  # padding is not data
    assert ours.same_but_padding(bytes(theirs))
    theirs[at - 8] ^= 0xFF  # the count is
    assert not ours.same_but_padding(bytes(theirs))
    theirs[at - 8] ^= 0xFF
    theirs[at] ^= 0xFF  # and position[0]
    assert not ours.same_but_padding(bytes(theirs))


def test_fields_fixed_at_construction_and_errors_that_say_what():
    js = Serialized(JointState, name=["a"], position=1)
    with pytest.raises(AttributeError, match="only numbers"):
        js.header.frame_id = "b"
    with pytest.raises(TypeError, match="no field 'positions'"):
        Serialized(JointState, positions=3)
    with pytest.raises(KeyError, match="no field"):
        js.view("header.frame")
    with pytest.raises(ValueError, match="not a number"):
        js.view("header")
    with pytest.raises(TypeError, match="not a ROS 2 message class"):
        Serialized(dict)
    with pytest.raises(ValueError):  # a view has the sequence's length, fixed
        js.position[:] = (1.0, 2.0)


def test_the_codec_passes_the_bytes_and_checks_the_type():
    codec = codec_for(JointState)
    js = Serialized(JointState, name=["a"], position=1)
    assert codec.encode(js) is js._cdr  # no copy: the channel copies it at once
    assert codec.decode(bytes(codec.encode(js))) == js.to_message()
    # a plain message goes through rclpy: the same data, and padding that rclpy leaves
    # uninitialised (two of its serialisations of one message may differ there)
    assert js.same_but_padding(bytes(codec.encode(js.to_message())))
    with pytest.raises(TypeError, match="port of nav_msgs/msg/Odometry"):
        codec_for(Odometry).encode(js)


def test_the_codec_refuses_a_layout_that_differs_from_rclpy(monkeypatch):
    class Wrong(Serialized):
        __slots__ = ()

        def same_but_padding(self, other: bytes) -> bool:
            return False

    monkeypatch.setattr(_codec, "Serialized", Wrong)
    monkeypatch.setattr(_codec, "_checked", {})
    with pytest.raises(ConfigurationError, match="TwistStamped"):
        codec_for(TwistStamped)


@pytest.mark.parametrize("cls", [JointState, Odometry, TwistStamped, Float64MultiArray])
def test_every_field_used(cls):
    fields = example_fields(cls)
    ours = Serialized(cls, **fields)
    assert deserialize_message(bytes(ours), cls) == ours.to_message()
    assert ours.same_but_padding(serialize_message(ours.to_message()))
