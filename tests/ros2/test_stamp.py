"""A component stamps a real ROS 2 std_msgs/Header with its iteration's ROS time."""

from std_msgs.msg import Header

from .._stamping import stamped_headers


def test_stamp_to_fills_a_ros2_header_stamp():
    headers = stamped_headers(Header)
    assert [(h.stamp.sec, h.stamp.nanosec) for h in headers] == [(0, 0), (0, 500_000_000), (1, 0)]
