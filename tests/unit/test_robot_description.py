"""Reading the robot description (rtcf._core._robot_description): the URDFs of
ros2_control's own tests (ros2_control_test_assets/components_urdfs.hpp) parsed to its
schema, its checks and their words, the joints' limits, and the arm example's URDF."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from rtcf import ConfigurationError, JointLimits
from rtcf._core._robot_description import (
    ActuatorInfo,
    AsyncParams,
    ComponentInfo,
    InterfaceInfo,
    JointInfo,
    MimicJoint,
    SoftJointLimits,
    TransmissionInfo,
    joint_limits,
    parse,
)

INF = math.inf
PI = 3.14159265359  # as the URDF writes it
EXAMPLES = Path(__file__).resolve().parents[2] / "src" / "rtcf_examples"

# ros2_control_test_assets' urdf_head, in short: joint1 and joint2 revolute, joint3
# continuous, tool_joint fixed; joint4 prismatic with a safety controller
HEAD = """<?xml version="1.0"?>
<robot name="MinimalRobot">
  <link name="world"/>
  <link name="base_link"/>
  <link name="link1"/>
  <link name="link2"/>
  <link name="link3"/>
  <link name="link4"/>
  <link name="tool_link"/>
  <joint name="base_joint" type="fixed">
    <parent link="world"/><child link="base_link"/>
  </joint>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/><child link="link1"/>
    <limit lower="-3.14159265359" upper="3.14159265359" effort="0.2" velocity="0.2"/>
  </joint>
  <joint name="joint2" type="revolute">
    <parent link="link1"/><child link="link2"/>
    <limit lower="-3.14159265359" upper="3.14159265359" effort="0.1" velocity="0.2"/>
  </joint>
  <joint name="joint3" type="continuous">
    <parent link="link2"/><child link="link3"/>
  </joint>
  <joint name="joint4" type="prismatic">
    <parent link="link3"/><child link="link4"/>
    <limit lower="0" upper="0.5" effort="30" velocity="0.4"/>
    <safety_controller soft_lower_limit="-0.1" soft_upper_limit="0.4" k_position="10"
                       k_velocity="20"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="link4"/><child link="tool_link"/>
  </joint>
"""
TAIL = "</robot>\n"

# a system with joints, a sensor and gpios, <param>s at every level
SYSTEM = """
  <ros2_control name="RRBotSystemWithGPIO" type="system" rw_rate="25">
    <hardware>
      <plugin>ros2_control_demo_hardware/RRBotSystemWithGPIOHardware</plugin>
      <group>Hardware Group</group>
      <param name="example_param_write_for_sec">2</param>
      <param name="example_param_read_for_sec"> 3 </param>
    </hardware>
    <joint name="joint1">
      <command_interface name="position">
        <param name="min">-1</param>
        <param name="max">1</param>
        <param name="initial_value">1.2</param>
        <param name="register">1</param>
      </command_interface>
      <command_interface name="velocity">
        <param name="min">-1.5</param>
        <param name="max">0.1</param>
      </command_interface>
      <state_interface name="position">
        <param name="register">3</param>
      </state_interface>
      <state_interface name="velocity"/>
      <param name="modbus_server_ip"> 1.1.1.1</param>
    </joint>
    <joint name="joint2">
      <command_interface name="position"/>
      <state_interface name="position"/>
      <state_interface name="status" data_type="bool"/>
    </joint>
    <sensor name="tcp_fts_sensor">
      <state_interface name="fx"/>
      <state_interface name="tz"/>
      <param name="frame_id">kuka_tcp</param>
    </sensor>
    <gpio name="flange_IOS">
      <command_interface name="digital_output" size="2" data_type="bool"/>
      <state_interface name="analog_input" size="3"/>
      <state_interface name="vacuum">
        <param name="initial_value">1.0</param>
      </state_interface>
    </gpio>
  </ros2_control>
"""

# an actuator with a transmission (valid_urdf_ros2_control_actuator_only)
ACTUATOR = """
  <ros2_control name="ActuatorModularJoint1" type="actuator">
    <hardware>
      <plugin>ros2_control_demo_hardware/VelocityActuatorHardware</plugin>
      <param name="example_param_write_for_sec">1.13</param>
    </hardware>
    <joint name="joint1">
      <command_interface name="velocity">
        <param name="min">-1</param>
        <param name="max">1</param>
      </command_interface>
      <state_interface name="velocity"/>
    </joint>
    <transmission name="transmission1">
      <plugin>transmission_interface/RotationToLinerTansmission</plugin>
      <joint name="joint1" role="joint1">
        <mechanical_reduction>325.949</mechanical_reduction>
      </joint>
      <param name="additional_special_parameter">1337</param>
    </transmission>
  </ros2_control>
"""

# a gripper: right_finger mimics left_finger (gripper_urdf_head and its resources)
GRIPPER_HEAD = """<?xml version="1.0"?>
<robot name="Gripper">
  <link name="base"/><link name="left"/><link name="right"/>
  <joint name="left_finger_joint" type="prismatic">
    <parent link="base"/><child link="left"/>
    <limit lower="0" upper="0.04" effort="100" velocity="0.2"/>
  </joint>
  <joint name="right_finger_joint" type="prismatic">
    <parent link="base"/><child link="right"/>
    <mimic joint="left_finger_joint" multiplier="2" offset="1"/>
    <limit lower="0" upper="0.04" effort="0" velocity="0"/>
  </joint>
"""


def gripper(mimic: str = "", command: bool = False, head: str = GRIPPER_HEAD) -> str:
    right_command = '<command_interface name="position"/>' if command else ""
    return head + f"""
  <ros2_control name="TestGripper" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="left_finger_joint">
      <command_interface name="position"/>
      <state_interface name="position"/>
    </joint>
    <joint name="right_finger_joint" {mimic}>
      {right_command}
      <state_interface name="position"/>
    </joint>
  </ros2_control>
""" + TAIL


def error(urdf: str) -> str:
    with pytest.raises(ConfigurationError) as caught:
        parse(urdf)
    text = str(caught.value)
    assert "\n" not in text
    return text


# --------------------------------------------------------------------------- the schema


def test_a_system_with_joints_sensors_and_gpios_parses_to_every_field() -> None:
    (info,) = parse(HEAD + SYSTEM + TAIL)
    assert (info.name, info.type) == ("RRBotSystemWithGPIO", "system")
    assert info.hardware_plugin_name == "ros2_control_demo_hardware/RRBotSystemWithGPIOHardware"
    assert info.group == "Hardware Group"
    assert info.hardware_parameters == {
        "example_param_write_for_sec": "2", "example_param_read_for_sec": "3"}
    assert (info.rw_rate, info.is_async, info.async_params) == (25, False, AsyncParams())
    assert info.original_xml == HEAD + SYSTEM + TAIL
    assert info.transmissions == () and info.mimic_joints == ()

    joint1, joint2 = info.joints
    assert joint1 == ComponentInfo(
        name="joint1", type="joint",
        command_interfaces=(
            InterfaceInfo("position", min="-1", max="1", initial_value="1.2",
                          parameters={"min": "-1", "max": "1", "initial_value": "1.2",
                                      "register": "1"}),
            InterfaceInfo("velocity", min="-1.5", max="0.1",
                          parameters={"min": "-1.5", "max": "0.1"})),
        state_interfaces=(InterfaceInfo("position", parameters={"register": "3"}),
                          InterfaceInfo("velocity")),
        parameters={"modbus_server_ip": "1.1.1.1"}, is_mimic=None, enable_limits=True)
    assert joint2.command_interfaces == (InterfaceInfo("position"),)
    assert joint2.state_interfaces[1] == InterfaceInfo("status", data_type="bool")
    assert joint2.state_interfaces[0].data_type == "double"
    assert joint2.state_interfaces[0].size == 1

    (sensor,) = info.sensors
    assert sensor == ComponentInfo(
        "tcp_fts_sensor", "sensor", (), (InterfaceInfo("fx"), InterfaceInfo("tz")),
        {"frame_id": "kuka_tcp"})
    (gpio,) = info.gpios
    assert gpio.type == "gpio"
    assert gpio.command_interfaces == (InterfaceInfo("digital_output", data_type="bool", size=2),)
    assert gpio.state_interfaces == (
        InterfaceInfo("analog_input", size=3),
        InterfaceInfo("vacuum", initial_value="1.0", parameters={"initial_value": "1.0"}))


def test_an_actuator_with_a_transmission_gets_its_joint_and_actuator1() -> None:
    (info,) = parse(HEAD + ACTUATOR + TAIL)
    assert info.type == "actuator"
    assert info.hardware_parameters == {"example_param_write_for_sec": "1.13"}
    assert info.transmissions == (TransmissionInfo(
        name="transmission1", type="transmission_interface/RotationToLinerTansmission",
        joints=(JointInfo("joint1", "joint1", ("velocity",), ("velocity",), 325.949),),
        actuators=(ActuatorInfo("actuator1", "actuator1", ("velocity",), ("velocity",)),),
        parameters={"additional_special_parameter": "1337"}),)


def test_a_system_transmission_reads_its_actuators_and_offsets() -> None:
    urdf = HEAD + """
  <ros2_control name="RRBotModularWrist" type="system">
    <hardware><plugin>ros2_control_demo_hardware/ActuatorHardwareMultiDOF</plugin></hardware>
    <joint name="joint1"><command_interface name="position"/>
      <state_interface name="position"/></joint>
    <joint name="joint2"><command_interface name="position"/>
      <state_interface name="position"/></joint>
    <transmission name="transmission1">
      <plugin>transmission_interface/DifferentialTransmission</plugin>
      <actuator name="joint1_motor" role="actuator1" read_only="true"/>
      <actuator name="joint2_motor" role="actuator2"/>
      <joint name="joint1" role="joint1">
        <mechanical_reduction>10</mechanical_reduction>
        <offset>0.5</offset>
      </joint>
      <joint name="joint2" role="joint2" read_only="false">
        <mechanical_reduction>50</mechanical_reduction>
      </joint>
    </transmission>
  </ros2_control>
""" + TAIL
    (transmission,) = parse(urdf)[0].transmissions
    assert transmission.actuators == (
        ActuatorInfo("joint1_motor", "actuator1", read_only=True),
        ActuatorInfo("joint2_motor", "actuator2"))
    assert transmission.joints == (
        JointInfo("joint1", "joint1", ("position",), ("position",), 10.0, 0.5),
        JointInfo("joint2", "joint2", ("position",), ("position",), 50.0, 0.0, False))


def test_several_tags_and_async_properties() -> None:
    urdf = HEAD + """
  <ros2_control name="TestActuatorHardware" type="actuator" is_async="true" thread_priority="40">
    <hardware><plugin>test_actuator</plugin></hardware>
    <properties><async affinity="[0, 2]" scheduling_policy="DETACHED" print_warnings="false"/>
    </properties>
    <joint name="joint1"><command_interface name="position"/></joint>
  </ros2_control>
  <ros2_control name="TestSensorHardware" type="sensor" rw_rate="20">
    <hardware><plugin>test_sensor</plugin></hardware>
    <sensor name="sensor1"><state_interface name="velocity"/></sensor>
  </ros2_control>
""" + TAIL
    actuator, sensor = parse(urdf)
    assert actuator.is_async and actuator.rw_rate == 0
    assert actuator.async_params == AsyncParams(40, "detached", (0, 2), False)
    assert (sensor.name, sensor.type, sensor.rw_rate, sensor.is_async) == (
        "TestSensorHardware", "sensor", 20, False)


def test_mimic_joints_follow_the_urdf_unless_the_tag_says_false() -> None:
    expected = (MimicJoint("right_finger_joint", "left_finger_joint", 1, 0, 2.0, 1.0),)
    (info,) = parse(gripper())
    assert info.mimic_joints == expected
    assert info.joints[1].is_mimic is None
    (info,) = parse(gripper('mimic="true"'))
    assert info.mimic_joints == expected and info.joints[1].is_mimic is True
    (info,) = parse(gripper('mimic="false"', command=True))
    assert info.mimic_joints == () and info.joints[1].is_mimic is False


# --------------------------------------------------------------------------- the limits


def test_urdf_limits_narrowed_by_the_interfaces_min_and_max() -> None:
    (info,) = parse(HEAD + SYSTEM + TAIL)
    # position [-1, 1] inside the URDF's +-pi; velocity min(|-1.5|, 0.1, URDF 0.2)
    assert info.limits["joint1"] == JointLimits(-1.0, 1.0, 0.1, INF, 0.2)
    # no min/max on its interface: the URDF's alone
    assert info.limits["joint2"] == JointLimits(-PI, PI, 0.2, INF, 0.1)
    assert set(info.limits) == {"joint1", "joint2"}
    assert info.soft_limits == {}


def test_a_continuous_joint_has_no_position_limits_but_its_interfaces() -> None:
    urdf = HEAD + """
  <ros2_control name="Wheels" type="system">
    <hardware><plugin>p</plugin></hardware>
    <joint name="joint3"><command_interface name="velocity"/></joint>
    <joint name="joint1"><command_interface name="position">
      <param name="min">-0.5</param></command_interface></joint>
  </ros2_control>
""" + TAIL
    (info,) = parse(urdf)
    assert info.limits["joint3"] == JointLimits()  # no <limit>, no min/max
    assert info.limits["joint1"] == JointLimits(-0.5, PI, 0.2, INF, 0.2)
    urdf = urdf.replace('<command_interface name="velocity"/>',
                        '<command_interface name="position"><param name="min">-2</param>'
                        '<param name="max">2</param></command_interface>'
                        '<command_interface name="effort"><param name="max">5</param>'
                        '</command_interface><command_interface name="acceleration">'
                        '<param name="max">3</param></command_interface>'
                        '<command_interface name="jerk"><param name="max">9</param>'
                        '</command_interface>')
    assert parse(urdf)[0].limits["joint3"] == JointLimits(-2.0, 2.0, INF, 3.0, 5.0)


def test_disabled_limits_drop_that_kind_or_all() -> None:
    urdf = HEAD + """
  <ros2_control name="R" type="system">
    <hardware><plugin>p</plugin></hardware>
    <joint name="joint1">
      <command_interface name="position"><limits enable="false"/>
        <param name="min">-1</param><param name="max">1</param></command_interface>
      <command_interface name="velocity"><param name="max">0.05</param></command_interface>
    </joint>
    <joint name="joint2"><limits enable="false"/>
      <command_interface name="position"><param name="min">-1</param></command_interface>
    </joint>
  </ros2_control>
""" + TAIL
    (info,) = parse(urdf)
    assert info.joints[0].command_interfaces[0].enable_limits is False
    assert info.joints[1].enable_limits is False
    assert info.joints[1].command_interfaces[0].enable_limits is False
    assert info.limits["joint1"] == JointLimits(-INF, INF, 0.05, INF, 0.2)
    assert info.limits["joint2"] == JointLimits()


def test_soft_limits_from_the_safety_controller_within_the_hard_ones() -> None:
    urdf = HEAD + """
  <ros2_control name="Lift" type="actuator">
    <hardware><plugin>p</plugin></hardware>
    <joint name="joint4"><command_interface name="position"/></joint>
  </ros2_control>
""" + TAIL
    (info,) = parse(urdf)
    assert info.limits["joint4"] == JointLimits(0.0, 0.5, 0.4, INF, 30.0)
    assert info.soft_limits["joint4"] == SoftJointLimits(0.0, 0.4, 10.0, 20.0)


def test_joint_limits_of_a_whole_description() -> None:
    # no <ros2_control>: the URDF's; fixed joints left out; zero velocity/effort: none
    limits = joint_limits(GRIPPER_HEAD + TAIL)
    assert limits == {"left_finger_joint": JointLimits(0.0, 0.04, 0.2, INF, 100.0),
                      "right_finger_joint": JointLimits(0.0, 0.04)}
    limits = joint_limits(HEAD + SYSTEM + TAIL)
    assert set(limits) == {"joint1", "joint2", "joint3", "joint4"}
    assert limits["joint1"] == JointLimits(-1.0, 1.0, 0.1, INF, 0.2)  # narrowed by the tag
    assert limits["joint3"] == JointLimits()
    assert limits["joint4"] == JointLimits(0.0, 0.5, 0.4, INF, 30.0)


# --------------------------------------------------------------------------- the errors


def test_xml_and_urdf_errors() -> None:
    assert error("") == "robot_description: empty URDF passed to robot"
    text = error('<robot name="r">\n  <link name="a">\n</robot>')
    assert text == ("robot_description:3: invalid URDF passed in to robot parser: mismatched "
                    "tag (line 3, column 3)")
    assert error('<sdf><model name="m"/></sdf>') == (
        "robot_description:1: the robot tag is not root element in URDF or sdf tag is not "
        "root element in SDF (the root is <sdf>; rtcf reads URDF only)")
    assert error(HEAD + TAIL) == "robot_description: no 'ros2_control' tag found in the URDF"
    missing = HEAD.replace('<limit lower="0" upper="0.5" effort="30" velocity="0.4"/>', "")
    assert re.fullmatch(r"robot_description:\d+: Failed to parse URDF file: Joint \[joint4\] is "
                        r"of type PRISMATIC but it does not specify limits",
                        error(missing + SYSTEM + TAIL))
    two_roots = GRIPPER_HEAD.replace('<link name="base"/>', '<link name="base"/><link name="x"/>')
    assert error(gripper(head=two_roots)).endswith(
        "Failed to parse URDF file: Two root links found: [base] and [x]")
    assert error(HEAD.replace('velocity="0.4"', "") + SYSTEM + TAIL).endswith(
        "Failed to parse URDF file: joint [joint4] <limit>: no velocity")
    assert error(HEAD.replace('type="continuous"', 'type="hinge"') + SYSTEM + TAIL).endswith(
        "Failed to parse URDF file: Joint [joint3] has no known type [hinge]")


def tag(body: str, attrs: str = 'name="R" type="system"') -> str:
    return HEAD + f"<ros2_control {attrs}>\n{body}\n</ros2_control>\n" + TAIL


PLUGIN = "<hardware><plugin>p</plugin></hardware>"
LINE = len(HEAD.splitlines()) + 1  # the <ros2_control> tag's line


@pytest.mark.parametrize(("urdf", "expected"), [
    (tag("<hardwarert><plugin>p</plugin></hardwarert>"),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <hardwarert>: invalid tag "
     "name 'hardwarert'"),
    (tag(PLUGIN, 'type="system"'),
     f"robot_description:{LINE}: <ros2_control>: no attribute 'name' in 'ros2_control' tag"),
    (tag(PLUGIN, 'name="R"'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: no attribute 'type' in "
     "'ros2_control' tag with name 'R'"),
    (tag(PLUGIN, 'name="R" type="robot"'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: invalid hardware type 'robot': "
     "expected 'system', 'actuator' or 'sensor'"),
    (tag('<joint name="joint1"/>'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: Missing <hardware> tag of "
     "<ros2_control> element for 'R' in your URDF."),
    (tag('<hardware><param name="some_param">1.0</param></hardware>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <hardware>: Missing <plugin> "
     "tag of <hardware> element for 'R' in your URDF."),
    (tag("<hardware><plugin>p</plugin><param>2</param></hardware>"),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <hardware> <param>: no "
     "parameter name attribute set in param tag for 'R'"),
    (tag(PLUGIN + '<joint name="joint1"><command_interface name="position"><param>1.0</param>'
                  "</command_interface></joint>"),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint1\"> "
     "<command_interface name=\"position\"> <param>: no parameter name attribute set in "
     "param tag for 'joint1'"),
    (tag(PLUGIN + '<joint name="joint1"><state_interface></state_interface></joint>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint1\"> "
     "<state_interface>: no attribute 'name' in 'state_interface' tag"),
    (tag(PLUGIN + '<joint name="joint9"><state_interface name="position"/></joint>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint9\">: "
     "Joint 'joint9' not found in URDF"),
    (tag(PLUGIN + '<joint name="tool_joint"><command_interface name="position"/></joint>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"tool_joint\">: "
     "Joint 'tool_joint' is of type 'fixed'. Fixed joints do not make sense in "
     "ros2_control."),
    (tag(PLUGIN + '<gpio name="io"><command_interface name="d" size="-4"/></gpio>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <gpio name=\"io\"> "
     "<command_interface name=\"d\">: Could not parse size tag in \"command_interface\". "
     "Got \"-4\", but expected a non-zero positive integer."),
    (tag(PLUGIN, 'name="R" type="system" rw_rate="-5"'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: Could not parse rw_rate tag in "
     "\"ros2_control\". Got \"-5\", but expected a positive integer."),
    (tag(PLUGIN, 'name="R" type="system" rw_rate="fast"'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: Could not parse rw_rate tag in "
     "\"ros2_control\". Invalid value: \"fast\", expected a positive integer."),
    (tag(PLUGIN, 'name="R" type="actuator" is_async="true" thread_priority="-30"'),
     f"robot_description:{LINE}: <ros2_control name=\"R\">: Could not parse thread_priority "
     "tag in \"ros2_control\". Got \"-30\", but expected a non-zero positive integer."),
    (tag(PLUGIN + '<joint name="joint1" mimic="yes"/>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint1\">: "
     "mimic: Input string : 'yes' is not a valid boolean value. Expected 'true' or 'false'."),
    (tag(PLUGIN + '<joint name="joint1"><command_interface name="velocity">'
                  '<param name="max">0.5"</param></command_interface></joint>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint1\"> "
     "<command_interface name=\"velocity\">: Error parsing the limits for the interface: "
     "velocity from the tags [min: '' and max: '0.5\"'] within ros2_control tag inside the "
     "URDF: give numbers"),
    (tag(PLUGIN + '<joint name="joint1"><command_interface name="position">'
                  '<param name="min">4</param></command_interface></joint>'),
     f"robot_description:{LINE + 1}: <ros2_control name=\"R\"> <joint name=\"joint1\">: the "
     "limits of joint 'joint1' from the URDF and its command interfaces: JointLimits: "
     "min_position 4 is above max_position 3.14159"),
])
def test_each_error_names_the_tag_in_ros2_controls_words(urdf: str, expected: str) -> None:
    assert error(urdf) == expected


def test_transmission_errors() -> None:
    mismatch = ACTUATOR.replace('<joint name="joint1" role="joint1">',
                                '<joint name="joint31415" role="joint1">')
    assert error(HEAD + mismatch + TAIL).endswith(
        "Error while parsing 'ActuatorModularJoint1'. Transmission 'transmission1' declared "
        "joint 'joint31415' is not available in component 'ActuatorModularJoint1'.")
    too_many = ACTUATOR.replace("</transmission>", '<joint name="joint1" role="j2"/>'
                                                   "</transmission>")
    assert error(HEAD + too_many + TAIL).endswith(
        "Error while parsing 'ActuatorModularJoint1'. There should be exactly one joint "
        "defined in this component but found 2.")
    no_plugin = ACTUATOR.replace(
        "<plugin>transmission_interface/RotationToLinerTansmission</plugin>", "")
    assert error(HEAD + no_plugin + TAIL).endswith(
        "<transmission name=\"transmission1\">: Missing <plugin> tag of <transmission> element "
        "for 'transmission1' in your URDF.")
    bad = ACTUATOR.replace("325.949", "fast")
    assert error(HEAD + bad + TAIL).endswith(
        "<mechanical_reduction>: <mechanical_reduction> is 'fast'; give a number")


def test_mimic_errors() -> None:
    no_mimic = GRIPPER_HEAD.replace(
        '<mimic joint="left_finger_joint" multiplier="2" offset="1"/>', "")
    assert error(gripper('mimic="true"', head=no_mimic)).endswith(
        "<joint name=\"right_finger_joint\">: Joint 'right_finger_joint' has no mimic "
        "information in the URDF")
    assert error(gripper(command=True)).endswith(
        "Joint 'right_finger_joint' has mimic attribute not set to false: Activated mimic "
        "joints cannot have command interfaces.")
    unknown = GRIPPER_HEAD.replace('mimic joint="left_finger_joint"', 'mimic joint="middle"')
    assert error(gripper(head=unknown)).endswith(
        "Mimic joint 'middle' not found in <ros2_control> tag")


# --------------------------------------------------------------------------- the arm


def test_the_arm_example_urdf_says_what_its_mujoco_model_says() -> None:
    urdf = (EXAMPLES / "description" / "arm.urdf").read_text()
    (info,) = parse(urdf, "arm.urdf")
    assert (info.name, info.type, info.hardware_plugin_name) == (
        "arm", "system", "rtcf_examples/MujocoSystem")
    model = ET.parse(EXAMPLES / "models" / "arm.xml").getroot()
    ranges = {j.get("name"): tuple(map(float, j.get("range", "").split()))
              for j in model.iter("joint") if j.get("name")}
    (effort,) = {tuple(map(float, m.get("ctrlrange", "").split()))
                 for m in model.iter("motor") if m.get("ctrlrange")}
    assert [j.name for j in info.joints] == list(ranges) == ["joint1", "joint2", "joint3"]
    for joint in info.joints:
        assert [i.name for i in joint.command_interfaces] == ["position", "velocity", "effort"]
        assert [i.name for i in joint.state_interfaces] == ["position", "velocity", "effort"]
        lower, upper = ranges[joint.name]
        limits = info.limits[joint.name]
        assert (limits.min_position, limits.max_position) == (lower, upper)
        assert limits.max_effort == effort[1] == -effort[0] == 60.0
    # the fixed joints (world to base, the tool) are no joints of the hardware
    assert joint_limits(urdf) == info.limits
