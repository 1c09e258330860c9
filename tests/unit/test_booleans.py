"""One boolean parser for every boolean parameter (issue 39's debt: the launch
reader and the ROS 2 launcher parsed them differently)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtcf._core._booleans import parse_bool
from rtcf._core._errors import ConfigurationError, RtcfError
from rtcf._core._settings import RunnerSettings
from rtcf._launch._files import load_deployment


@pytest.mark.parametrize(("value", "expected"), [
    (True, True), (False, False), ("true", True), ("False", False), (" TRUE ", True),
    ("1", True), ("0", False), (1, True), (0, False),
])
def test_what_is_a_boolean(value: object, expected: bool) -> None:
    assert parse_bool(value, "autostart") is expected


@pytest.mark.parametrize("value", ["no", "yes", "", "off", 2, 0.5, None, [True]])
def test_anything_else_is_an_error_naming_the_parameter(value: object) -> None:
    with pytest.raises(ConfigurationError) as info:
        parse_bool(value, "autostart")
    assert "'autostart'" in str(info.value) and repr(value) in str(info.value)


def test_launch_file_autostart_no_is_refused_naming_it(tmp_path: Path) -> None:
    # the ROS 2 launcher read "no" as false, the launch reader refused it: now both refuse
    path = tmp_path / "a.launch.xml"
    path.write_text("""<launch>
      <node pkg="rtcf" exec="rt_runner" name="rt_runner"/>
      <node pkg="rtcf" exec="rt_launcher" name="c" args="rtcf_examples.paper Sum">
        <param name="autostart" value="no"/>
      </node>
    </launch>""")
    with pytest.raises(RtcfError) as info:
        load_deployment([str(path)])
    assert "autostart" in str(info.value) and "'no'" in str(info.value)


def test_runner_settings_read_the_same_booleans() -> None:
    assert RunnerSettings.from_params({"lock_memory": "1"}).lock_memory is True
    with pytest.raises(ConfigurationError):
        RunnerSettings.from_params({"lock_memory": "no"})
    with pytest.raises(ConfigurationError):
        RunnerSettings.from_params({"lock_memory": 2})
