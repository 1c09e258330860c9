"""A component stamps a real ROS 1 std_msgs/Header (genpy Time) with its ROS time."""

from std_msgs.msg import Header

from .._stamping import stamped_headers


def test_stamp_to_fills_a_ros1_header_stamp():
    headers = stamped_headers(Header)
    assert [(h.stamp.secs, h.stamp.nsecs) for h in headers] == [(0, 0), (0, 500_000_000), (1, 0)]
    assert headers[2].stamp.to_nsec() == 1_000_000_000
