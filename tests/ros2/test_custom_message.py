"""A message type beyond std_msgs, end to end on ROS 2: the Identity example.

custom_message.launch.xml runs the original's Identity example with
geometry_msgs/msg/PointStamped (a header with a string and a time, and a nested
Point): /mapped/in -> identity1 -> /mapped/tmp (inside the runner only) -> identity2
-> /mapped/out, every field as it was.
"""


import pytest
from geometry_msgs.msg import Point, PointStamped  # fails loudly where it is missing
from std_msgs.msg import Header

from .._proc import interrupt, wait_for
from .conftest import start_rtcf
from .test_topics import spin_until

pytestmark = pytest.mark.integration


def test_pointstamped_through_the_identity_example(ros_node):
    proc = start_rtcf(
        "launch", "rtcf_examples", "custom_message.launch.xml", "--middleware", "ros2"
    )
    try:
        wait_for(proc, "running until Ctrl-C", timeout=60)
        sent = PointStamped(
            header=Header(frame_id="base_link/ärm", stamp=ros_node.get_clock().now().to_msg()),
            point=Point(x=1.0 / 3.0, y=-0.0, z=1e300),
        )
        got = []
        ros_node.create_subscription(PointStamped, "/mapped/out", got.append, 10)
        pub = ros_node.create_publisher(PointStamped, "/mapped/in", 10)
        assert spin_until(
            ros_node, lambda: bool(got), timeout=30, publish=lambda: pub.publish(sent)
        )
        out = got[-1]
        assert out.header.frame_id == "base_link/ärm"
        assert (out.header.stamp.sec, out.header.stamp.nanosec) == (
            sent.header.stamp.sec, sent.header.stamp.nanosec
        )
        assert (out.point.x, out.point.z) == (1.0 / 3.0, 1e300)
        assert str(out.point.y) == "-0.0"  # bit for bit, the sign of zero too
        types = dict(ros_node.get_topic_names_and_types())
        assert types["/mapped/out"] == ["geometry_msgs/msg/PointStamped"]
        assert "/mapped/tmp" not in types  # blacklisted: it stays inside the runner
    finally:
        _, err = interrupt(proc)
    assert proc.returncode == 0, err
    assert "geometry_msgs/msg/PointStamped" in err  # what rtcf launch says it maps
