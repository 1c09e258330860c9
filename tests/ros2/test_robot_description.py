"""The robot description a run uses: xacro through a launch file's $(command ...) under
rtcf launch, and /robot_description (transient local) received by rt_runner."""

import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from rtcf._core._robot_description import parse
from rtcf._launch._deployment import plan
from rtcf._launch._xml import parse_launch_file, parse_launch_string

from .._proc import read_rest, wait_for, wait_for_match
from .conftest import FIXTURES, rtcf_env, start_rtcf

pytestmark = pytest.mark.integration

DESCRIPTION = Path(str(resources.files("rtcf_examples") / "description"))
BRINGUP = FIXTURES / "arm_description.launch.xml"
BIN = Path(sys.executable).parent


def xacro(*args):
    return subprocess.run([str(BIN / "xacro"), str(DESCRIPTION / "arm.urdf.xacro"), *args],
                          capture_output=True, text=True, check=True).stdout


def test_xacro_expands_through_the_launch_file():
    mock = plan(parse_launch_file(BRINGUP))
    assert mock.robot_description == xacro("use_mock_hardware:=true")
    (arm,) = mock.hardware
    assert arm.hardware_plugin_name == "mock_components/GenericSystem"
    assert [j.name for j in arm.joints] == ["joint1", "joint2", "joint3"]
    # without the mock: the same HardwareInfo as arm.urdf's (text aside)
    real = plan(parse_launch_file(BRINGUP, {"use_mock_hardware": "false"}))
    assert real.hardware == parse((DESCRIPTION / "arm.urdf").read_text())


def test_xacros_find_resolves_through_this_pythons_ament_index(tmp_path, monkeypatch):
    # rtcf is in this venv's ament index (pyproject's data-files); xacro's $(find) uses
    # ament_index_python, which reads only AMENT_PREFIX_PATH: rtcf adds the venv to it
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    robot = tmp_path / "r.urdf.xacro"
    robot.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                     '<link name="$(find rtcf)"/></robot>')
    description = parse_launch_string(
        f'<launch><node pkg="p" exec="e" name="n"><param name="d" '
        f"value=\"$(command '$(find-exec xacro) {robot}')\"/></node></launch>")
    assert f'<link name="{sys.prefix}/share/rtcf"/>' in description.parameters.get("/n/d")


def test_rtcf_launch_reports_the_description_it_runs_with():
    proc = start_rtcf("launch", BRINGUP, "--sim", "--duration", "0.05")
    _, err = read_rest(proc)
    assert proc.returncode == 0, err
    assert (
        "rtcf: runner /rt_runner: robot description from robot_state_publisher "
        "/robot_state_publisher's parameter robot_description (topic /robot_description) "
        f"({BRINGUP}:8): hardware arm (system, mock_components/GenericSystem: 3 joints)"
    ) in err


def test_a_failing_xacro_is_one_line_and_rtcf_launch_fails():
    proc = start_rtcf("launch", BRINGUP, "use_mock_hardware:=maybe", "--sim", "--duration", "1")
    _, err = read_rest(proc)
    assert proc.returncode != 0
    (line,) = [w for w in err.splitlines() if "$(command" in w]
    assert line.startswith(f"rtcf: error: {BRINGUP}:8: $(command '")
    assert "arm.urdf.xacro use_mock_hardware:=maybe') failed: exited with code" in line
    assert "; stderr: " in line and "maybe" in line.partition("; stderr: ")[2]


# --------------------------------------------------------------------------- rt_runner


def start_runner(*args):
    return subprocess.Popen(
        [str(BIN / "rt_runner"), "--ros-args", "-p", "mode:=no_wait", "-p", "frequency:=100.0",
         *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
        env=rtcf_env())


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(subprocess.signal.SIGINT)
    return read_rest(proc)


def test_rt_runner_takes_robot_description_from_the_topic(ros_node):
    qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    publisher = ros_node.create_publisher(String, "/robot_description", qos)
    publisher.publish(String(data=xacro("use_mock_hardware:=true")))
    me = ros_node.get_fully_qualified_name()
    # published before the runner starts: transient local keeps it for the runner (which
    # names the publisher when discovery has named it already)
    runner = start_runner("-r", "__node:=rt_runner_description")
    try:
        wait_for(runner, "subscribed to /robot_description for the robot description")
        wait_for_match(runner, r"robot description from topic /robot_description"
                               rf"( \(published by {me}\))?: hardware arm \(system, "
                               r"mock_components/GenericSystem: 3 joints\)")
        wait_for(runner, "ready")
    finally:
        _, err = stop(runner)
    assert runner.returncode == 0, err
    assert "error" not in err, err


def test_rt_runner_refuses_a_broken_description_and_goes_on(ros_node, tmp_path):
    qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    publisher = ros_node.create_publisher(String, "/arm/robot_description", qos)
    broken = xacro().replace('<joint name="joint2">', '<joint name="joint7">')
    publisher.publish(String(data=broken))
    runner = start_runner("-r", "__node:=rt_runner", "-r", "__ns:=/arm")
    try:
        match = wait_for_match(
            runner, r"error: the robot description on /arm/robot_description is refused, "
                    r"waiting for another: /arm/robot_description:\d+: <ros2_control "
                    r"name=\"arm\"> <joint name=\"joint7\">: Joint 'joint7' not found in URDF")
        assert match
        wait_for(runner, "ready")
    finally:
        _, err = stop(runner)
    assert runner.returncode == 0, err


def test_rt_runner_takes_its_own_parameter_first(tmp_path):
    params = tmp_path / "params.yaml"
    import yaml

    params.write_text(yaml.safe_dump(
        {"/rt_runner_param": {"ros__parameters": {"robot_description": xacro()}}}))
    runner = start_runner("-r", "__node:=rt_runner_param", "--params-file", params)
    try:
        wait_for(runner, "robot description from /rt_runner_param's parameter "
                         "robot_description: hardware arm (system, "
                         "rtcf_examples/MujocoSystem: 3 joints)")
        wait_for(runner, "ready")
    finally:
        _, err = stop(runner)
    assert runner.returncode == 0, err
    assert "unknown parameter" not in err and "subscribed to" not in err, err
