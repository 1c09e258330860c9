"""A component's params.set() under ROS 2: a parameter of its node (or the runner's)."""

import pytest
from rcl_interfaces.srv import GetParameters

from .._launches import launch_xml, runner_xml
from .test_parameters import call
from .test_topics import launched

pytestmark = pytest.mark.integration

LAUNCH = launch_xml("""
  <node name="setter" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components SetsParameters"/>
""", runner_xml(100.0))


def test_a_parameter_set_in_configure_is_a_parameter_of_the_components_node(
    ros_node, tmp_path
):
    with launched(tmp_path / "set.launch", text=LAUNCH):
        own = call(ros_node, GetParameters, "/setter/get_parameters",
                   GetParameters.Request(names=["calibrated"]))
        assert [v.double_value for v in own.values] == [42.5]
        # not the component's own: on the runner's node, under its full name
        shared = call(ros_node, GetParameters, "/rt_runner/get_parameters",
                      GetParameters.Request(names=["shared.answer"]))
        assert [v.string_value for v in shared.values] == ["yes"]
