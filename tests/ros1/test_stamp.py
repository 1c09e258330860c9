"""A component stamps a real ROS 1 std_msgs/Header (genpy Time) with its ROS time."""

from std_msgs.msg import Header

from rtcf.testing import run_components

from .._stamping import StampsHeader


class Stamps(StampsHeader):
    header_type = Header


def test_stamp_to_fills_a_ros1_header_stamp():
    trace = run_components([Stamps], iterations=3, frequency=2.0)
    stamps = [(h.stamp.secs, h.stamp.nsecs) for h in trace.outputs["/header"]]
    assert stamps == [(0, 0), (0, 500_000_000), (1, 0)]
    assert trace.outputs["/header"][2].stamp.to_nsec() == 1_000_000_000
