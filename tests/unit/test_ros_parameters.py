"""ROS 2 parameters files have one reader (issue 39's debt: a launch file's <param
from=...> and the controller manager's files were read by two, which accepted
different files)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtcf._core._errors import RtcfError
from rtcf._launch._controller_setup import read_setup
from rtcf._launch._files import load_deployment

BAD = """\
rt_runner:
  ros__parameters:
    frequency: 100.0
other_node:
  gain: 3
"""


def _launch(tmp_path: Path) -> str:
    (tmp_path / "params.yaml").write_text(BAD)
    path = tmp_path / "a.launch.xml"
    path.write_text("""<launch>
      <node pkg="rtcf" exec="rt_runner" name="rt_runner"/>
      <node pkg="rtcf" exec="rt_launcher" name="sum" args="rtcf_examples.paper Sum">
        <param from="params.yaml"/>
      </node>
    </launch>""")
    return str(path)


def test_an_entry_without_ros_parameters_is_refused_by_both_alike(tmp_path: Path) -> None:
    launch = _launch(tmp_path)
    with pytest.raises(RtcfError) as by_launch:
        load_deployment([launch])
    with pytest.raises(RtcfError) as by_manager:
        read_setup([str(tmp_path / "params.yaml")], "/controller_manager")
    for info in (by_launch, by_manager):
        assert "'other_node' has no 'ros__parameters' mapping" in str(info.value)
        assert str(tmp_path / "params.yaml") in str(info.value)
