"""Controller types by their ros2_control name: the entry-point group rtcf.controllers."""

from __future__ import annotations

import importlib

import pytest

import rtcf_controllers
from rtcf._core._errors import ConfigurationError
from rtcf._launch._controller_types import GROUP, controller_types, resolve


def test_every_rtcf_controller_is_declared_under_its_ros2_control_type() -> None:
    classes = [getattr(rtcf_controllers, n) for n in rtcf_controllers.__all__]
    assert sorted(c.ros2_control_type for c in classes) == [
        t for t in controller_types() if resolve(t)[0] == "rtcf_controllers"]
    for cls in classes:
        module, name = resolve(cls.ros2_control_type)
        assert getattr(importlib.import_module(module), name) is cls


def test_an_unknown_type_names_itself_and_what_is_installed() -> None:
    with pytest.raises(ConfigurationError) as info:
        resolve("my_controllers/Missing")
    message = str(info.value)
    assert "'my_controllers/Missing'" in message and GROUP in message
    assert "pid_controller/PidController" in message and "\n" not in message
