"""A component stamps a real ROS 2 std_msgs/Header with its iteration's ROS time."""

from std_msgs.msg import Header

from rtcf.testing import run_components

from .._stamping import StampsHeader


class Stamps(StampsHeader):
    header_type = Header


def test_stamp_to_fills_a_ros2_header_stamp():
    trace = run_components([Stamps], iterations=3, frequency=2.0)
    stamps = [(h.stamp.sec, h.stamp.nanosec) for h in trace.outputs["/header"]]
    assert stamps == [(0, 0), (0, 500_000_000), (1, 0)]
