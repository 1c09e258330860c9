"""A component's params.set() under ROS 1: onto the parameter server."""

import pytest
import rospy

from .._launches import launch_xml, runner_xml
from .test_parameters import forget, launch, stop

pytestmark = pytest.mark.integration

LAUNCH = launch_xml("""
  <node name="setter" pkg="rtcf" type="rt_launcher" args="rtcf_ros1_components SetsParameters"/>
""", runner_xml(100.0))


def test_a_parameter_set_in_configure_lands_on_the_parameter_server(tmp_path, ros_node):
    forget("/setter", "/shared")
    proc = launch(tmp_path, LAUNCH)
    try:
        assert rospy.get_param("/setter/calibrated") == 42.5
        assert rospy.get_param("/shared/answer") == "yes"
    finally:
        if proc.poll() is None:
            stop(proc)
        forget("/setter", "/shared", "/rt_runner")
