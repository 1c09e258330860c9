"""ROS 1's rt_runner takes its robot description as ros_control does: the parameter
``robot_description`` searched from its namespace up (a launch file's ``<param
textfile|command>``), and runs the description's hardware in its loop."""

from pathlib import Path

import pytest
import rosgraph

from .._proc import wait_for
from ._launch import end, start
from .conftest import PORT

pytestmark = pytest.mark.integration


@pytest.fixture(autouse=True)
def _no_description_left(roscore):
    # roslaunch leaves a launch file's <param>s on the master when it ends: a broken
    # description left there would reach every later runner of the session
    yield
    master = rosgraph.Master("/test_robot_description")
    if master.hasParam("/robot_description"):
        master.deleteParam("/robot_description")

URDF = Path(__file__).parents[1] / "ros2" / "controllers" / "fixtures" / "arm_gripper.urdf"


def _launch(tmp_path: Path, description: str) -> Path:
    path = tmp_path / "bringup.launch"
    path.write_text(f"""<launch>
  <param name="robot_description" textfile="{description}"/>
  <group ns="robot">
    <node name="rt_runner" pkg="rtcf" type="rt_runner">
      <param name="mode" value="wait_for_components"/>
      <param name="num_components_expected" value="1"/>
      <param name="frequency" value="100.0"/>
    </node>
    <node name="example" pkg="rtcf" type="rt_launcher" args="rtcf_examples PaperExample">
      <param name="runner" value="/robot/rt_runner"/>
    </node>
  </group>
</launch>
""")
    return path


def test_rt_runner_runs_the_hardware_of_the_parameter_server_description(roscore, tmp_path):
    launch = start("roslaunch", "--screen", "-p", PORT, _launch(tmp_path, str(URDF)))
    try:
        said = wait_for(launch, "/robot/rt_runner: running", timeout=60)
        # found from /robot up, as ros_control's node handle finds it
        assert ("/robot/rt_runner: robot description from parameter /robot_description: "
                "hardware arm (system, mock_components/GenericSystem: 4 joints)") in said, said
    finally:
        (err,) = end(launch)
    # the loop ran with the hardware built in its worker (a description the worker could
    # not build would have ended the run at its start)
    assert "/robot/rt_runner: stopped after" in err and "after 0 iterations" not in err, err


def test_a_broken_description_is_one_line_naming_the_parameter(roscore, tmp_path):
    broken = tmp_path / "broken.urdf"
    # the URDF's joint3 renamed: its <ros2_control> tag names a joint the URDF lacks
    broken.write_text(URDF.read_text().replace('<joint name="joint3"', '<joint name="joint9"',
                                               1))
    launch = start("roslaunch", "--screen", "-p", PORT, _launch(tmp_path, str(broken)))
    try:
        said = wait_for(launch, "/robot/rt_runner: error:", timeout=60)
    finally:
        (err,) = end(launch)
    line = next(x for x in (said + err).splitlines() if "/robot/rt_runner: error:" in x)
    assert "/robot_description" in line and "joint" in line, line
