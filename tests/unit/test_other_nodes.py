"""rtcf launch's other nodes (_cli._other_nodes), what is decided before any process
starts: where ros2 run finds an executable (the ament index of AMENT_PREFIX_PATH), the
line for a package that is not installed, the command line in launch_ros' order, the
parameters file as launch_ros writes one; and on_exit / required as the reader keeps
them."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import yaml

from rtcf._cli._other_nodes import (
    NotInstalled,
    check_lines,
    command,
    find_executable,
    write_params_file,
)
from rtcf._core._errors import Location
from rtcf._launch._description import NodeDescription
from rtcf._launch._xml import parse_launch_file


def prefix_with(root: Path, package: str, *executables: str) -> Path:
    index = root / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True, exist_ok=True)
    (index / package).write_text("")
    libexec = root / "lib" / package
    libexec.mkdir(parents=True, exist_ok=True)
    for name in executables:
        (libexec / name).write_text("#!/bin/sh\n")
        (libexec / name).chmod(0o755)
    return root


def test_the_executable_is_found_as_ros2_run_finds_it(tmp_path: Path) -> None:
    first = prefix_with(tmp_path / "a", "demo", "talker")
    second = prefix_with(tmp_path / "b", "demo", "talker", "listener")
    env = {"AMENT_PREFIX_PATH": f"{first}:{second}"}
    # the first prefix whose index registers the package, as get_package_prefix
    assert find_executable("demo", "talker", env) == f"{first}/lib/demo/talker"
    with pytest.raises(NotInstalled) as info:  # not looked for in the second prefix
        find_executable("demo", "listener", env)
    assert str(info.value) == (
        f"package 'demo' ({first}) has no executable 'listener' in {first}/lib/demo "
        "(it has: talker); correct exec=, or reinstall the package")


def test_a_package_not_installed_is_one_line_that_says_what_to_do(tmp_path: Path) -> None:
    with pytest.raises(NotInstalled) as info:
        find_executable("robot_state_publisher", "robot_state_publisher",
                        {"AMENT_PREFIX_PATH": str(tmp_path)})
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith(f"package 'robot_state_publisher' is not installed (no ament index "
                           f"of {tmp_path}, {sys.prefix} registers it); install it "
                           "(ros-jazzy-robot-state-publisher, or build it into a prefix)")


def test_the_command_line_is_in_launch_ros_order(tmp_path: Path) -> None:
    node = NodeDescription("demo", "talker", "talker", "/robot", Location("b.launch.xml", 3),
                           "ros2", args="one 'two words' --ros-args --log-level debug",
                           remaps=[("chatter", "/chat"), ("~/x", "y")],
                           params_files=["/cfg/a.yaml"])
    assert command(node, "/p/lib/demo/talker", "/tmp/launch_params_1") == [
        "/p/lib/demo/talker", "one", "two words", "--ros-args", "--log-level", "debug",
        "--ros-args", "-r", "__node:=talker", "-r", "__ns:=/robot",
        "--params-file", "/cfg/a.yaml", "--params-file", "/tmp/launch_params_1",
        "-r", "chatter:=/chat", "-r", "~/x:=y"]


def test_the_parameters_file_is_launch_ros_one(tmp_path: Path) -> None:
    path = write_params_file({"rate": 5.5, "gains": {"p": 2}, "names": ["a", "b"],
                              "text": "1.0"})
    try:
        assert yaml.safe_load(Path(path).read_text()) == {"/**": {"ros__parameters": {
            "rate": 5.5, "gains": {"p": 2}, "names": ["a", "b"], "text": "1.0"}}}
        assert Path(path).name.startswith("launch_params_")
    finally:
        Path(path).unlink()


def test_on_exit_shutdown_and_required_are_kept(tmp_path: Path) -> None:
    ros2 = tmp_path / "a.launch.xml"
    ros2.write_text("""<launch>
  <node pkg="demo" exec="talker" name="a" on_exit="shutdown"/>
  <node pkg="demo" exec="talker" name="b" output="screen"/>
</launch>""")
    a, b = parse_launch_file(str(ros2), {}).nodes
    assert (a.on_exit, b.on_exit, b.output) == ("shutdown", None, "screen")
    ros1 = tmp_path / "a.launch"
    ros1.write_text("""<launch>
  <node pkg="demo" type="talker" name="a" required="true"/>
  <node pkg="demo" type="talker" name="b" required="false"/>
</launch>""")
    a, b = parse_launch_file(str(ros1), {}).nodes
    assert (a.on_exit, b.on_exit) == ("shutdown", None)


def test_rtcf_check_says_what_rtcf_launch_would_start(tmp_path: Path) -> None:
    root = prefix_with(tmp_path, "demo", "talker")
    nodes = [NodeDescription("demo", "talker", "t", "/", Location("b.launch.xml", 3), "ros2"),
             NodeDescription("gone", "x", "g", "/", Location("b.launch.xml", 4), "ros2")]
    first, second = check_lines(nodes, {"AMENT_PREFIX_PATH": str(root)})
    assert first == f"note: b.launch.xml:3: node /t: rtcf launch starts {root}/lib/demo/talker"
    assert second.startswith("warning: b.launch.xml:4: node /g not started: package 'gone' "
                             "is not installed")
