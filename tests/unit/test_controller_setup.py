"""A ros2_control YAML read as its controller manager reads it (_launch._controller_setup),
and given to a runner in a ROS 2 launch file (<param from=...> on the rt_runner node)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtcf import LaunchError
from rtcf._core._errors import ConfigurationError
from rtcf._core._settings import RunnerSettings
from rtcf._launch._controller_setup import params_key_matches, read_setup
from rtcf._launch._files import load_deployment

CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 250
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    arm_controller:
      type: joint_trajectory_controller/JointTrajectoryController
/**:
  ros__parameters:
    use_sim_time: false
arm_controller:
  ros__parameters:
    joints: [j1, j2]
    gains:
      j1: {p: 2.0}
joint_state_broadcaster:
  ros__parameters:
    frame_id: base
"""


def write(tmp_path: Path, text: str, name: str = "controllers.yaml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_the_managers_section_gives_rate_and_types_and_each_controller_its_own(
    tmp_path: Path,
) -> None:
    setup = read_setup([write(tmp_path, CONTROLLERS)], "/controller_manager")
    assert setup.update_rate == 250.0
    assert setup.types == {
        "joint_state_broadcaster": "joint_state_broadcaster/JointStateBroadcaster",
        "arm_controller": "joint_trajectory_controller/JointTrajectoryController",
    }
    # nested parameters flattened with '.', as ROS 2 names them; /** applies to all
    assert setup.params_for("/arm_controller") == {
        "use_sim_time": False, "joints": ["j1", "j2"], "gains.j1.p": 2.0}
    assert setup.params_for("/joint_state_broadcaster")["frame_id"] == "base"
    # another manager's name: none of it
    other = read_setup([write(tmp_path, CONTROLLERS)], "/robot/cm")
    assert other.update_rate is None and other.types == {}


def test_later_files_win_and_namespaced_keys_match(tmp_path: Path) -> None:
    first = write(tmp_path, CONTROLLERS)
    second = write(tmp_path, "/robot/controller_manager:\n  ros__parameters:\n"
                   "    update_rate: 100\n", "override.yaml")
    setup = read_setup([first, second], "/robot/controller_manager")
    assert setup.update_rate == 100.0  # the unqualified key matched too, the later won
    assert "arm_controller" in setup.types
    assert params_key_matches("/robot/*", "/robot/x")
    assert not params_key_matches("/robot/*", "/other/x")
    assert params_key_matches("robot/x", "/robot/x") and params_key_matches("x", "/robot/x")


def test_update_rate_sets_the_frequency_unless_given_and_different(tmp_path: Path) -> None:
    setup = read_setup([write(tmp_path, CONTROLLERS)], "/controller_manager")
    settings = RunnerSettings.from_params({})
    setup.set_frequency(settings, given=False, where="rt_runner /r")
    assert settings.frequency == 250.0
    assert not any("frequency" in n for n in settings.notes)
    same = RunnerSettings.from_params({"frequency": 250.0})
    setup.set_frequency(same, given=True, where="rt_runner /r")
    differ = RunnerSettings.from_params({"frequency": 1000.0})
    with pytest.raises(ConfigurationError) as info:
        setup.set_frequency(differ, given=True, where="rt_runner /r")
    message = str(info.value)
    assert "rt_runner /r" in message and "1000" in message and "250" in message
    assert "\n" not in message
    # an update_rate the loop cannot run at is the runner's error, naming the file
    fast = read_setup([write(tmp_path, "controller_manager:\n  ros__parameters:\n"
                             "    update_rate: 2000000\n", "fast.yaml")], "/controller_manager")
    with pytest.raises(ConfigurationError) as info:
        fast.set_frequency(RunnerSettings.from_params({}), given=False, where="rt_runner /r")
    assert "fast.yaml" in str(info.value) and "not feasible" in str(info.value)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("controller_manager:\n  ros__parameters:\n    update_rate: -1\n", "update_rate"),
        ("controller_manager:\n  ros__parameters:\n    a:\n      type: 3\n", "a.type"),
        ("controller_manager:\n  update_rate: 1\n", "ros__parameters"),
        ("- a\n", "must map node names"),
        ("a: [\n", "not valid YAML"),
    ],
)
def test_a_bad_file_is_one_line_naming_it(tmp_path: Path, text: str, words: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigurationError) as info:
        read_setup([path], "/controller_manager")
    assert path in str(info.value) and words in str(info.value)
    assert "\n" not in str(info.value)


def launch(tmp_path: Path, runner_params: str) -> str:
    write(tmp_path, CONTROLLERS)
    path = tmp_path / "bringup.launch.xml"
    path.write_text(f"""<launch>
      <node pkg="rtcf" exec="rt_runner" name="rt_runner">
        {runner_params}
        <param from="controllers.yaml"/>
      </node>
    </launch>""")
    return str(path)


def test_a_launch_files_runner_takes_the_managers_section(tmp_path: Path) -> None:
    target = load_deployment([launch(tmp_path, "")]).runner
    assert target.settings.frequency == 250.0
    assert target.controllers is not None
    assert target.controllers.types["arm_controller"].endswith("JointTrajectoryController")
    named = load_deployment([launch(tmp_path, '<param name="controller_manager" value="cm"/>')])
    assert named.runner.controllers is not None and named.runner.controllers.types == {}


def test_a_launch_files_frequency_and_a_different_update_rate_are_an_error(
    tmp_path: Path,
) -> None:
    path = launch(tmp_path, '<param name="frequency" value="500.0"/>')
    with pytest.raises(LaunchError) as info:
        load_deployment([path])
    assert info.value.file == path and "update_rate 250 Hz" in str(info.value)
