"""Recording under ROS 1: rtcf launch --middleware ros1 --record on the original's
SumTest. What arrived on /rtcf/ros/in and what every component wrote is in the MCAP
file (std_msgs schemas), read back by rosbags: out is three times in, iteration by
iteration."""

from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import Float64

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, rtcf_launch

pytestmark = pytest.mark.integration


def test_sum_test_recorded_on_ros1(topics, tmp_path):
    path = tmp_path / "sum.mcap"
    launch = rtcf_launch("rtcf_examples", "sum_test.launch", "--record", path)
    try:
        wait_for(launch, "running until Ctrl-C", timeout=30)
        got = topics.sub("/rtcf/ros/out", Float64)
        pub = topics.pub("/rtcf/ros/in", Float64)
        for value in (-10.0, 20.0, 1234.5):
            assert wait_until(
                lambda v=value: bool(got) and got[-1].data == 3 * v,
                10.0,
                publish=lambda v=value: pub.publish(Float64(v)),
            ), (value, [m.data for m in got[-5:]])
    finally:
        (err,) = end(launch)
    assert f"into {path}; dropped: 0" in err, err
    by_topic = {}
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as r:
        for con, _, raw in r.messages():
            msg = r.deserialize(raw, con.msgtype)
            by_topic.setdefault(con.topic, []).append(msg.data)
    assert set(by_topic) >= {"/rtcf/ros/in", "/rtcf/sum1", "/rtcf/ros/out"}
    fed = [v for k, v in enumerate(by_topic["/rtcf/ros/in"])
           if k == 0 or by_topic["/rtcf/ros/in"][k - 1] != v]
    assert fed == [-10.0, 20.0, 1234.5]
    # the sums of every iteration: out = 3 * the input it read
    assert {3 * v for v in fed} <= set(by_topic["/rtcf/ros/out"])


def test_a_ros1_message_type_is_recorded_as_ros1msg(topics, tmp_path):
    """rtcf_example_msgs/Custom through the Identity example: the channels carry ros1
    messages with their genpy definitions; genpy reads every field back."""
    from geometry_msgs.msg import Point
    from mcap.reader import make_reader
    from rtcf_example_msgs.msg import Custom

    path = tmp_path / "custom.mcap"
    launch = rtcf_launch("rtcf_examples", "custom_message.launch", "--record", path)
    sent = Custom(a=1.0 / 3.0, b=-2.5e-300, point=Point(x=1e300, y=-0.0, z=42.0))
    try:
        wait_for(launch, "running until Ctrl-C", timeout=30)
        got = topics.sub("/mapped/out", Custom)
        pub = topics.pub("/mapped/in", Custom)
        assert wait_until(lambda: bool(got), 20.0, publish=lambda: pub.publish(sent))
    finally:
        (err,) = end(launch)
    assert f"into {path}; dropped: 0" in err, err
    with open(path, "rb") as f:
        reader = make_reader(f)
        seen = {}
        for schema, channel, message in reader.iter_messages():
            if channel.topic.endswith("/iteration_info"):
                continue  # the loop's timing rows (std_msgs, ros2msg)
            assert (schema.encoding, channel.message_encoding) == ("ros1msg", "ros1")
            assert schema.name == "rtcf_example_msgs/Custom"
            assert schema.data.decode() == Custom._full_text
            seen.setdefault(channel.topic, []).append(Custom().deserialize(message.data))
    assert set(seen) == {"/mapped/in", "/mapped/tmp", "/mapped/out"}
    out = seen["/mapped/out"][-1]
    assert (out.a, out.b, out.point.x, out.point.z) == (1.0 / 3.0, -2.5e-300, 1e300, 42.0)
    assert str(out.point.y) == "-0.0"
