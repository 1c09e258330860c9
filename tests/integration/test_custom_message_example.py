"""The custom-message example's launch files without ROS: the chain is sound, and a
message package that is not there is an error that says which type.

tests/ros1/test_custom_message.py and tests/ros2/test_custom_message.py run them with
their message types on ROS 1 and ROS 2.
"""

import pytest

from rtcf_examples._components import message_class

from .conftest import run_rtcf

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("file", ["custom_message.launch", "custom_message.launch.xml"])
def test_the_example_runs_with_a_plain_type(file):
    result = run_rtcf(
        "launch", "rtcf_examples", file, "msg_type:=float", "--sim", "--duration", "0.1"
    )
    assert result.returncode == 0, result.stderr
    assert "rtcf: order: /identity1 -> /identity2" in result.stderr


def test_a_missing_message_package_is_an_error_that_names_the_type():
    result = run_rtcf("launch", "rtcf_examples", "custom_message.launch", "--sim")
    assert result.returncode == 1
    assert "component '/identity1'" in result.stderr
    assert "msg_type 'rtcf_example_msgs/Custom' cannot be imported" in result.stderr


def test_type_names_of_both_ros_versions():
    assert message_class("float") is float and message_class("str") is str
    for bad in ("Custom", "a/b/c", "pkg/srv/T", "/T"):
        with pytest.raises(ValueError, match="is not float, int, bool, str"):
            message_class(bad)
    with pytest.raises(ValueError, match="cannot be imported"):
        message_class("no_such_pkg/msg/T")
