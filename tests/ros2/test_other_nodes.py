"""A bringup's other nodes under ``rtcf launch`` (rtcf._cli._other_nodes): a real ROS 2
executable, installed in an ament prefix of the test's own on AMENT_PREFIX_PATH as
ament_python installs one (``lib/<pkg>/<exec>``, the package's marker in the ament
index), is started as ros2 launch starts it: the graph shows it with its name and
namespace, its remapped topic, its parameters (asked through its parameter service),
its args; it is stopped with SIGINT when the loop ends. A node whose package is not
installed is one line and the run goes on; one that exits early is one line, and stops
the loop only with on_exit="shutdown". A spawner's --controller-ros-args remap shows in
the graph too."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rcl_interfaces.srv import GetParameters

from .. import _proc
from .conftest import rtcf_env
from .test_parameters import call
from .test_topics import spin_until

pytestmark = pytest.mark.integration

PACKAGE = "rtcf_test_nodes"
# an rclpy node as an ament_python package installs one: a script in lib/<pkg>/
NODE = """\
#!{python}
import os
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String


def main():
    rclpy.init(args=sys.argv)
    node = Node("param_node", allow_undeclared_parameters=True,
                automatically_declare_parameters_from_overrides=True)
    node.create_publisher(String, "chatter", 10)
    node.create_subscription(String, "~/input", lambda message: None, 10)
    print("args:", rclpy.utilities.remove_ros_args(sys.argv)[1:], flush=True)
    print("stdout env:", os.environ.get("RTCF_TEST_ENV"), flush=True)
    node.get_logger().info("up")
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    print("stopped cleanly", flush=True)


main()
"""
EXITING = """\
#!/bin/sh
echo "exiting with $1" >&2
case "$2" in [0-9]*) sleep "$2" ;; esac
exit "$1"
"""
CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    forward_position_controller:
      type: forward_command_controller/ForwardCommandController
forward_position_controller:
  ros__parameters:
    joints: [joint1, joint2, joint3]
    interface_name: position
"""
PARAMS = """\
/**:
  ros__parameters:
    from_file: 7
    overridden: from the file
"""
BRINGUP = """\
<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="mode" value="no_wait"/>
    <param name="ros_mapping_whitelist" value="/fwd_commands"/>
    <param from="$(dirname)/controllers.yaml"/>
  </node>
  <node pkg="rtcf" exec="rt_launcher" name="hardware"
        args="tests.ros2.controllers._plants PositionJoints">
    <param name="is_first" value="true"/>
  </node>
  <node pkg="controller_manager" exec="spawner"
        args="forward_position_controller --controller-ros-args '-r ~/commands:=/fwd_commands'"/>
  <group>
    <push-ros-namespace namespace="robot"/>
    <node pkg="rtcf_test_nodes" exec="param_node" name="talker" args="hello --flag"
          output="screen">
      <param from="$(dirname)/params.yaml"/>
      <param name="rate" value="5.5"/>
      <param name="overridden" value="inline"/>
      <param name="gains">
        <param name="p" value="2"/>
      </param>
      <remap from="chatter" to="/remapped_chatter"/>
      <env name="RTCF_TEST_ENV" value="set"/>
    </node>
  </group>
  <node pkg="rtcf_test_nodes" exec="exiting" name="quitter" args="3"/>
  <node pkg="not_installed_pkg" exec="nothing" name="missing"/>
</launch>
"""


def install_prefix(root: Path) -> Path:
    """An ament prefix holding package rtcf_test_nodes with two executables."""
    index = root / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / PACKAGE).write_text("")
    libexec = root / "lib" / PACKAGE
    libexec.mkdir(parents=True)
    for name, text in (("param_node", NODE.format(python=sys.executable)),
                       ("exiting", EXITING.format())):
        (libexec / name).write_text(text)
        (libexec / name).chmod(0o755)
    return root


def env_for(prefix: Path) -> dict[str, str]:
    env = rtcf_env()
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(
        filter(None, [str(prefix), env.get("AMENT_PREFIX_PATH", "")]))
    env["ROS_LOG_DIR"] = str(prefix / "log")
    return env


def bringup(tmp_path: Path, text: str = BRINGUP) -> Path:
    (tmp_path / "controllers.yaml").write_text(CONTROLLERS)
    (tmp_path / "params.yaml").write_text(PARAMS)
    path = tmp_path / "bringup.launch.xml"
    path.write_text(text)
    return path


def parameters(node, target: str, names: list[str]) -> list:
    response = call(node, GetParameters, f"{target}/get_parameters",
                    GetParameters.Request(names=names), timeout=20)
    return [_value(v) for v in response.values]


def _value(v):
    return {1: v.bool_value, 2: v.integer_value, 3: v.double_value, 4: v.string_value}.get(v.type)


def test_rtcf_launch_starts_the_other_nodes_as_ros2_launch_and_stops_them(
    ros_node, tmp_path: Path
) -> None:
    prefix = install_prefix(tmp_path / "install")
    proc = _proc.start_rtcf(env_for(prefix), "launch", bringup(tmp_path), "--middleware", "ros2")
    try:
        _proc.wait_running(proc, timeout=60)
        assert spin_until(ros_node, lambda: ("talker", "/robot") in
                          ros_node.get_node_names_and_namespaces(), timeout=20)
        # its remapped topic (<remap>), its private one (its name and namespace), and the
        # spawner's --controller-ros-args remap of the controller's ~/commands
        wanted = {"/remapped_chatter", "/robot/talker/input", "/fwd_commands"}
        assert spin_until(ros_node, lambda: wanted <= set(dict(
            ros_node.get_topic_names_and_types())), timeout=20)
        topics = dict(ros_node.get_topic_names_and_types())
        assert "/chatter" not in topics and "/robot/chatter" not in topics
        assert "/forward_position_controller/commands" not in topics
        # the parameters: its <param>s over its <param from> file's, as ros2 launch gives them
        assert parameters(ros_node, "/robot/talker",
                          ["rate", "from_file", "overridden", "gains.p"]) == [
            5.5, 7, "inline", 2]
        pid = int(_proc.wait_for_match(proc, r"node /robot/talker: started "
                                       r"rtcf_test_nodes/param_node \[param_node-1\], "
                                       r"pid (\d+)").group(1))
        proc.send_signal(signal.SIGINT)  # not from a terminal: rtcf sends the nodes SIGINT
        out, err = _proc.read_rest(proc, timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # stopped (and reaped)
    lines = err.splitlines()
    # the node's output, prefixed as ros2 launch prefixes it: args before --ros-args
    assert "[param_node-1] args: ['hello', '--flag']" in out
    assert "[param_node-1] stdout env: set" in out
    assert "[param_node-1] stopped cleanly" in out
    assert any(line.startswith("[param_node-1] [INFO]") and "up" in line for line in lines)
    # one line for the missing package, naming file, line and package; the run went on
    (missing,) = [line for line in lines if "/missing" in line]
    assert missing.startswith(f"rtcf: warning: {tmp_path}/bringup.launch.xml:28: node /missing "
                              "not started: package 'not_installed_pkg' is not installed")
    assert "install it" in missing
    # an early exit: one line with its code; the loop went on
    (quit_line,) = [line for line in lines if "node /quitter (" in line]
    assert "exited with code 3" in quit_line and quit_line.endswith("the loop goes on")
    assert "rtcf: node /robot/talker: stopped (sent SIGINT), exited with code 0" in lines
    # the quitter's stderr reached the terminal (output "log": stderr on screen)
    assert "[exiting-2] exiting with 3" in lines


def test_a_required_node_that_exits_stops_the_loop(tmp_path: Path) -> None:
    prefix = install_prefix(tmp_path / "install")
    text = BRINGUP.replace('name="quitter" args="3"/>',
                           'name="quitter" args="4 1" on_exit="shutdown"/>')
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", str(bringup(tmp_path, text))],
        env=env_for(prefix), capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 1, result.stderr
    assert time.monotonic() - started < 30
    assert "node /quitter (rtcf_test_nodes/exiting" in result.stderr
    assert "exited with code 4" in result.stderr and "stopping the loop" in result.stderr
    assert "stopped abnormally" in result.stderr
    assert "rtcf: node /robot/talker: stopped (sent SIGINT), exited with code 0" in \
        result.stderr.splitlines()
