"""ros2_control spawner nodes in a ROS 2 launch file (_launch._spawner): their args as
the spawner reads them, and the components they add to the runner of their controller
manager (type from its YAML section, parameters, namespace, inactive), from real files."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtcf import LaunchError
from rtcf._core._errors import Location
from rtcf._launch._description import NodeDescription
from rtcf._launch._files import load_deployment
from rtcf._launch._spawner import default_name, parse

CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    arm_controller:
      type: joint_trajectory_controller/JointTrajectoryController
    base_controller:
      type: diff_drive_controller/DiffDriveController
arm_controller:
  ros__parameters:
    joints: [j1, j2]
    gains:
      j1: {p: 2.0}
    update_rate: 50
joint_state_broadcaster:
  ros__parameters:
    joints: [j1, j2]
"""


def spawner(args: str, namespace: str = "/") -> NodeDescription:
    return NodeDescription("controller_manager", "spawner", default_name(args), namespace,
                           Location("bringup.launch.xml", 7), "ros2", args=args)


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def launch(tmp_path: Path, body: str, runner: str = "") -> str:
    write(tmp_path, "controllers.yaml", CONTROLLERS)
    return write(tmp_path, "bringup.launch.xml", f"""<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="mode" value="no_wait"/>
    {runner or '<param from="$(dirname)/controllers.yaml"/>'}
  </node>
  {body}
</launch>""")


def specs(tmp_path: Path, body: str, runner: str = "") -> dict:
    target = load_deployment([launch(tmp_path, body, runner)]).runner
    return {spec.full_name: spec for spec in target.components}


def error(tmp_path: Path, body: str, runner: str = "") -> LaunchError:
    with pytest.raises(LaunchError) as info:
        load_deployment([launch(tmp_path, body, runner)])
    return info.value


# -- the args ------------------------------------------------------------------------


def test_args_as_the_spawner_reads_them() -> None:
    request = parse(spawner("a b --inactive -c /robot/cm --switch-timeout 3 -u"))
    assert request.names == ["a", "b"]
    assert request.manager == "/robot/cm" and request.inactive
    assert request.ignored == ["--switch-timeout", "-u"]
    plain = parse(spawner("a", namespace="/robot"))
    assert plain.manager == "/robot/controller_manager" and not plain.inactive
    assert parse(spawner("a -n /other --controller-manager=cm")).manager == "/other/cm"
    assert parse(spawner("a -t pid_controller/PidController")).type_name.startswith("pid")
    # served: --activate-as-group is what rtcf does anyway (no warning)
    assert parse(spawner("a b --activate-as-group")).ignored == []
    assert parse(spawner("a --load-only")).load_only  # loaded unconfigured


def test_controller_ros_args_are_the_controllers_remaps_and_parameters() -> None:
    request = parse(spawner(
        "a --controller-ros-args '-r ~/cmd_vel:=/cmd_vel -p gain:=2 -p names:=[x,y]' "
        "--controller-ros-args '--ros-args --remap odom:=/odom --param frame:=odom'"))
    assert request.options.remaps == [("~/cmd_vel", "/cmd_vel"), ("odom", "/odom")]
    assert request.options.params == {"gain": 2, "names": ["x", "y"], "frame": "odom"}


def test_spawner_nodes_are_named_as_the_spawner_names_itself() -> None:
    named = default_name("-c cm joint_state_broadcaster --inactive")
    assert named == "spawner_joint_state_broadcaster"


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        ("a --controller-ros-args '-r __ns:=/x'", "the remap '__ns:=/x' is not read"),
        ("a --controller-ros-args '--log-level debug'", "'--log-level' is not read"),
        ("a --controller-ros-args '-p gain'", "-p 'gain' is not NAME:=VALUE"),
        ("a --controller-ros-args -r", "--controller-ros-args '-r': -r needs a value"),
        ("--controller a", "option --controller is not supported"),
        ("a --frobnicate", "unknown option '--frobnicate' in args"),
        ("a -p", "option -p needs a value"),
        ("--inactive", "args names no controller"),
        ("a -p /no/such/file.yaml", "-p/--param-file '/no/such/file.yaml' does not exist"),
    ],
)
def test_args_rtcf_cannot_honour_are_one_line_naming_them(args: str, fragment: str) -> None:
    with pytest.raises(LaunchError) as info:
        parse(spawner(args))
    assert str(info.value).startswith("bringup.launch.xml:7: spawner '/spawner")
    assert fragment in str(info.value) and "\n" not in str(info.value)


# -- the components ------------------------------------------------------------------


def test_each_name_is_a_component_of_its_type_with_its_sections_parameters(
    tmp_path: Path,
) -> None:
    loaded = specs(tmp_path, """
  <node pkg="controller_manager" exec="spawner" args="joint_state_broadcaster"/>
  <node pkg="controller_manager" exec="spawner" args="arm_controller base_controller --inactive"/>
""")
    assert list(loaded) == ["/joint_state_broadcaster", "/arm_controller", "/base_controller"]
    jsb, arm, base = loaded.values()
    assert (jsb.module, jsb.class_name) == ("rtcf_controllers", "JointStateBroadcaster")
    assert arm.class_name == "JointTrajectoryController"
    assert base.class_name == "DiffDriveController"
    assert jsb.autostart and not arm.autostart and not base.autostart
    assert arm.params["joints"] == ["j1", "j2"] and arm.params["gains/j1/p"] == 2.0
    assert arm.rate.rate == 50.0 and jsb.rate.rate == 0.0  # its section's update_rate
    assert jsb.location is not None and jsb.location.line == 7
    assert not (jsb.unconfigured or arm.unconfigured or base.unconfigured)


def test_load_only_loads_it_unconfigured(tmp_path: Path) -> None:
    loaded = specs(tmp_path, """
  <node pkg="controller_manager" exec="spawner" args="arm_controller --load-only"/>""")
    arm = loaded["/arm_controller"]
    assert arm.unconfigured and not arm.autostart


def test_a_param_file_overrides_the_runners_and_may_give_the_type(tmp_path: Path) -> None:
    extra = write(tmp_path, "extra.yaml", """\
arm_controller:
  ros__parameters:
    joints: [a1]
pid:
  ros__parameters:
    type: pid_controller/PidController
    dof_names: [j1]
""")
    loaded = specs(tmp_path, f"""
  <node pkg="controller_manager" exec="spawner" args="arm_controller pid -p {extra}"/>""")
    assert loaded["/arm_controller"].params["joints"] == ["a1"]
    assert loaded["/arm_controller"].params["gains/j1/p"] == 2.0  # the runner's file still
    assert loaded["/pid"].class_name == "PidController"
    assert "type" not in loaded["/pid"].params


def test_controllers_live_in_the_controller_managers_namespace(tmp_path: Path) -> None:
    loaded = specs(tmp_path, """
  <group><push-ros-namespace namespace="robot"/>
    <node pkg="controller_manager" exec="spawner" args="joint_state_broadcaster"/>
  </group>""", runner="""<param name="controller_manager" value="/robot/controller_manager"/>
    <param from="$(dirname)/controllers.yaml"/>""")
    assert list(loaded) == ["/robot/joint_state_broadcaster"]
    assert loaded["/robot/joint_state_broadcaster"].params["joints"] == ["j1", "j2"]


def test_a_name_without_a_type_names_the_file_the_name_and_the_section(tmp_path: Path) -> None:
    exc = error(tmp_path, '<node pkg="controller_manager" exec="spawner" args="gripper"/>')
    assert exc.file is not None and exc.file.endswith("bringup.launch.xml") and exc.line == 6
    assert "controller 'gripper' has no type" in str(exc)
    assert "controller manager /controller_manager's section" in str(exc)
    assert "controllers.yaml" in str(exc) and "'gripper.type'" in str(exc)


def test_an_uninstalled_type_and_an_unknown_manager_are_errors(tmp_path: Path) -> None:
    exc = error(tmp_path, """
  <node pkg="controller_manager" exec="spawner" args="x -t nowhere/Nothing"/>""")
    assert "controller 'x': controller type 'nowhere/Nothing' is not installed" in str(exc)
    exc = error(tmp_path, """
  <node pkg="controller_manager" exec="spawner" args="arm_controller -c /robot/cm"/>""")
    assert "controller manager /robot/cm is no runner's (theirs: /controller_manager)" in str(exc)


def test_ignored_options_are_warned_about_and_spawners_are_no_other_nodes(
    tmp_path: Path,
) -> None:
    deployment = load_deployment([launch(tmp_path, """
  <node pkg="controller_manager" exec="spawner" args="arm_controller --switch-asap"/>""")])
    assert deployment.other_nodes == []
    (warning,) = [w for w in deployment.warnings if "spawner" in w]
    assert "bringup.launch.xml:7: spawner '/spawner_arm_controller': --switch-asap ignored" \
        in warning


def test_ros2_control_node_given_the_yaml_is_the_runner_and_its_controller_manager(
    tmp_path: Path,
) -> None:
    write(tmp_path, "controllers.yaml", CONTROLLERS)
    path = write(tmp_path, "team.launch.xml", """<launch>
  <node pkg="controller_manager" exec="ros2_control_node">
    <param from="$(dirname)/controllers.yaml"/>
    <remap from="~/robot_description" to="/robot_description"/>
  </node>
  <node pkg="controller_manager" exec="spawner" args="joint_state_broadcaster"/>
</launch>""")
    deployment = load_deployment([path])
    target = deployment.runner
    assert target.name == "/controller_manager" and target.settings.mode == "no_wait"
    assert target.settings.frequency == 100.0  # update_rate
    assert [s.full_name for s in target.components] == ["/joint_state_broadcaster"]
    assert deployment.warnings == []  # its types and update_rate are no unknown settings


# a bringup whose controller manager is named and given its update_rate as a <param>,
# its controllers' types in their own sections of a file only the spawners are given
SPAWNER_ONLY = """\
broadcaster:
  ros__parameters:
    type: joint_state_broadcaster/JointStateBroadcaster
"""


def named_manager(tmp_path: Path, params: str) -> str:
    write(tmp_path, "spawned.yaml", SPAWNER_ONLY)
    return write(tmp_path, "named.launch.xml", f"""<launch>
  <node pkg="controller_manager" exec="ros2_control_node" name="cm">{params}</node>
  <node pkg="controller_manager" exec="spawner"
        args="broadcaster -c cm -p $(dirname)/spawned.yaml"/>
</launch>""")


def test_ros2_control_node_runs_at_its_update_rate_param(tmp_path: Path) -> None:
    deployment = load_deployment([named_manager(
        tmp_path, '<param name="update_rate" value="10"/>')])
    target = deployment.runner
    assert target.name == "/cm" and target.settings.frequency == 10.0
    assert [s.full_name for s in target.components] == ["/broadcaster"]
    assert deployment.warnings == []


def test_ros2_control_node_without_update_rate_runs_at_ros2_controls_default(
    tmp_path: Path,
) -> None:
    deployment = load_deployment([named_manager(tmp_path, "")])
    assert deployment.runner.settings.frequency == 100.0
    assert [w.split(": ", 1)[1] for w in deployment.warnings] == [
        "ros2_control_node '/cm': update_rate not given, using ros2_control's default 100 Hz"]


def test_ros2_control_node_update_rate_as_the_node_reads_it(tmp_path: Path) -> None:
    """Its <param>s and its files' section in the file's order, later ones winning; a
    frequency of the runner's own must agree with it."""
    write(tmp_path, "controllers.yaml", CONTROLLERS)  # controller_manager: update_rate 100
    node = '<node pkg="controller_manager" exec="ros2_control_node">{}</node>'
    after = write(tmp_path, "after.launch.xml", "<launch>" + node.format(
        '<param from="$(dirname)/controllers.yaml"/><param name="update_rate" value="25"/>')
        + "</launch>")
    assert load_deployment([after]).runner.settings.frequency == 25.0
    both = write(tmp_path, "both.launch.xml", "<launch>" + node.format(
        '<param name="update_rate" value="25"/><param name="frequency" value="50.0"/>')
        + "</launch>")
    with pytest.raises(LaunchError, match=r"both.launch.xml:1: .*frequency 50 Hz and "
                       r"update_rate 25 Hz differ"):
        load_deployment([both])
    bad = write(tmp_path, "bad.launch.xml", "<launch>" + node.format(
        '<param name="update_rate" value="fast"/>') + "</launch>")
    with pytest.raises(LaunchError, match=r"update_rate 'fast' is not a positive number"):
        load_deployment([bad])


def test_ros2_control_node_puts_its_controllers_topics_on_ros(tmp_path: Path) -> None:
    """ros2_control's controllers' topics are ROS 2 topics: the node needs no whitelist
    (with hardware, the interfaces are no ports); one it is given wins."""
    settings = load_deployment([named_manager(tmp_path, "")]).runner.settings
    assert settings.maps_to_ros("/joint_states") and settings.maps_to_ros("/cmd_vel")
    given = load_deployment([named_manager(
        tmp_path, '<param name="ros_mapping_whitelist" value="/joint_states"/>')])
    assert given.runner.settings.maps_to_ros("/joint_states")
    assert not given.runner.settings.maps_to_ros("/cmd_vel")


def test_controller_ros_args_reach_the_component_and_win(tmp_path: Path) -> None:
    ros_file = write(tmp_path, "ros.yaml", """\
arm_controller:
  ros__parameters:
    joints: [r1, r2]
    state_publish_rate: 10.0
""")
    loaded = specs(tmp_path, f"""
  <node pkg="controller_manager" exec="spawner" args="arm_controller --controller-ros-args
    '-r ~/joint_trajectory:=/traj -p gains.j1.p:=3.5 --params-file {ros_file}'"/>
""")
    arm = loaded["/arm_controller"]
    assert arm.remaps == [("~/joint_trajectory", "/traj")]
    assert arm.params["gains/j1/p"] == 3.5  # -p over the runner's file
    assert arm.params["joints"] == ["r1", "r2"]  # --params-file over the runner's file
    assert arm.params["state_publish_rate"] == 10.0
