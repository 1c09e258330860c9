"""The robot description a runner of a launch file reads (rtcf._launch._robot_descriptions):
robot_state_publisher's parameter by topic, the runner's own, ROS 1's global one."""

from __future__ import annotations

import textwrap
from importlib import resources
from pathlib import Path

import pytest

from rtcf._core._errors import ConfigurationError
from rtcf._core._robot_description import parse
from rtcf._launch._deployment import Deployment, plan
from rtcf._launch._robot_descriptions import subscribed_topic
from rtcf._launch._xml import parse_launch_file

ARM = Path(str(resources.files("rtcf_examples") / "description" / "arm.urdf"))
CAT_ARM = "$(command 'cat $(find-pkg-share rtcf_examples)/description/arm.urdf')"
RUNNER = '<node pkg="rtcf" exec="rt_runner" name="rt_runner"><param name="mode" ' \
         'value="no_wait"/></node>'


def deploy(tmp_path: Path, body: str) -> Deployment:
    path = tmp_path / "bringup.launch.xml"
    path.write_text("<launch>\n" + textwrap.dedent(body).strip("\n") + "\n</launch>\n")
    return plan(parse_launch_file(path))


def test_robot_state_publishers_description_by_its_topic(tmp_path: Path) -> None:
    deployment = deploy(tmp_path, f"""
        <node pkg="robot_state_publisher" exec="robot_state_publisher"
              name="robot_state_publisher">
          <param name="robot_description" value="{CAT_ARM}"/>
        </node>
        <node pkg="controller_manager" exec="ros2_control_node"/>
        """)
    assert deployment.robot_description == ARM.read_text()
    assert deployment.hardware == parse(ARM.read_text())
    runner = deployment.runner
    assert runner.description is not None
    assert str(runner.description.location) == f"{tmp_path / 'bringup.launch.xml'}:4"
    assert deployment.notes == [
        "runner /controller_manager: robot description from robot_state_publisher "
        "/robot_state_publisher's parameter robot_description (topic /robot_description) "
        f"({tmp_path / 'bringup.launch.xml'}:4): hardware arm (system, "
        "rtcf_examples/MujocoSystem: 3 joints)"]


def test_the_topics_must_meet(tmp_path: Path) -> None:
    body = f"""
        <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp"
              namespace="arm">
          <param name="robot_description" value="{CAT_ARM}"/>
          REMAP
        </node>
        {RUNNER}
        """
    deployment = deploy(tmp_path, body.replace("REMAP", ""))
    assert deployment.robot_description is None
    assert any("reads the robot description from /robot_description, where no "
               "robot_state_publisher of the file publishes it (/arm/rsp on "
               "/arm/robot_description)" in w for w in deployment.warnings)
    remapped = body.replace("REMAP", '<remap from="robot_description" to="/robot_description"/>')
    assert deploy(tmp_path, remapped).robot_description == ARM.read_text()


def test_humble_style_remap_of_the_private_topic(tmp_path: Path) -> None:
    deployment = deploy(tmp_path, f"""
        <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">
          <param name="robot_description" value="{CAT_ARM}"/>
        </node>
        <group>
          <push-ros-namespace namespace="robot"/>
          <node pkg="controller_manager" exec="ros2_control_node">
            <remap from="~/robot_description" to="/robot_description"/>
          </node>
        </group>
        """)
    assert deployment.runner.name == "/robot/controller_manager"
    assert deployment.robot_description == ARM.read_text()


def test_the_runners_own_parameter_comes_first(tmp_path: Path) -> None:
    deployment = deploy(tmp_path, f"""
        <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">
          <param name="robot_description" value="&lt;robot name='other'/&gt;"/>
        </node>
        <node pkg="controller_manager" exec="ros2_control_node">
          <param name="robot_description" value="{CAT_ARM}"/>
        </node>
        """)
    assert deployment.robot_description == ARM.read_text()
    assert deployment.notes[0].startswith(
        "runner /controller_manager: robot description from ros2_control_node "
        "/controller_manager's parameter robot_description")
    assert any("Jazzy's controller manager ignores it" in w for w in deployment.warnings)
    # rt_runner's: no 'unknown parameter' note, no deprecation
    own = deploy(tmp_path, f"""
        <node pkg="rtcf" exec="rt_runner" name="rt_runner">
          <param name="mode" value="no_wait"/>
          <param name="robot_description" value="{CAT_ARM}"/>
        </node>
        """)
    assert own.hardware[0].name == "arm"
    assert not any("robot_description" in w for w in own.warnings), own.warnings


def test_ros1_global_parameter_from_a_command(tmp_path: Path) -> None:
    path = tmp_path / "robot.launch"
    path.write_text(textwrap.dedent(f"""
        <launch>
          <param name="robot_description" command="cat {ARM}"/>
          <group ns="arm">
            <node pkg="rtcf" type="rt_runner" name="rt_runner">
              <param name="mode" value="no_wait"/>
            </node>
          </group>
        </launch>
        """).lstrip())
    deployment = plan(parse_launch_file(path))
    assert deployment.robot_description == ARM.read_text()
    assert "parameter /robot_description" in deployment.notes[0]
    assert f"({path}:2)" in deployment.notes[0]


def test_errors_name_the_param_and_the_line_inside_the_description(tmp_path: Path) -> None:
    broken = tmp_path / "broken.urdf"
    broken.write_text(ARM.read_text().replace('<joint name="joint3">', '<joint name="joint9">'))
    line = ARM.read_text().splitlines().index('    <joint name="joint3">') + 1
    with pytest.raises(ConfigurationError) as info:
        deploy(tmp_path, f"""
            <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">
              <param name="robot_description" value="$(command 'cat {broken}')"/>
            </node>
            {RUNNER}
            """)
    assert str(info.value) == (
        f"{tmp_path / 'bringup.launch.xml'}:3: robot_description:{line}: "
        "<ros2_control name=\"arm\"> <joint name=\"joint9\">: Joint 'joint9' not found in URDF")


def test_a_description_without_ros2_control_has_no_hardware(tmp_path: Path) -> None:
    text = "&lt;robot name='r'&gt;&lt;link name='a'/&gt;&lt;/robot&gt;"
    deployment = deploy(tmp_path, f"""
        <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">
          <param name="robot_description" value="{text}"/>
        </node>
        {RUNNER}
        """)
    assert deployment.robot_description == "<robot name='r'><link name='a'/></robot>"
    assert deployment.hardware == []
    assert deployment.notes[0].endswith(": no <ros2_control> tag (no hardware)")


def test_no_description_anywhere(tmp_path: Path) -> None:
    deployment = deploy(tmp_path, RUNNER)
    assert deployment.robot_description is None
    assert deployment.hardware == []
    assert deployment.notes == []


def test_subscribed_topic() -> None:
    from rtcf._core._errors import Location
    from rtcf._launch._description import NodeDescription

    def node(namespace: str, remaps: list[tuple[str, str]]) -> NodeDescription:
        return NodeDescription("controller_manager", "ros2_control_node", "cm", namespace,
                               Location("f"), "ros2", remaps=remaps)

    assert subscribed_topic(node("/", [])) == "/robot_description"
    assert subscribed_topic(node("/a", [])) == "/a/robot_description"
    assert subscribed_topic(node("/a", [("robot_description", "/rd")])) == "/rd"
    assert subscribed_topic(node("/a", [("~/robot_description", "/rd2")])) == "/rd2"


def test_the_runners_description_file_gives_the_loop_its_hardware(tmp_path: Path) -> None:
    deployment = deploy(tmp_path, f"""
        <node pkg="rtcf" exec="rt_runner" name="rt_runner">
          <param name="robot_description_file" value="{ARM}"/>
        </node>
        """)
    assert deployment.robot_description == ARM.read_text()
    # the worker builds the hardware from the settings it is sent
    assert deployment.runner.settings.robot_description == ARM.read_text()
    assert deployment.notes[0].startswith(
        "runner /rt_runner: robot description from rt_runner /rt_runner's "
        "robot_description_file")


def test_a_description_file_that_cannot_be_read_names_its_param(tmp_path: Path) -> None:
    from rtcf._core._errors import LaunchError

    with pytest.raises(LaunchError, match=r"bringup\.launch\.xml:3: /rt_runner's "
                       r"robot_description_file '/nonexistent/robot\.urdf': cannot read it "
                       r"\(No such file or directory\)"):
        deploy(tmp_path, """
            <node pkg="rtcf" exec="rt_runner" name="rt_runner">
              <param name="robot_description_file" value="/nonexistent/robot.urdf"/>
            </node>
            """)
