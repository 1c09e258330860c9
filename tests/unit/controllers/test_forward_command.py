"""rtcf_controllers.forward_command_controller without ROS: std_msgs' Float64MultiArray
faked (a class with ``data``), commands refused as they arrive, naming joint and value."""

from __future__ import annotations

import logging
import math
import sys
import types
from dataclasses import dataclass, field

import pytest

import rtcf
from rtcf.testing import Trace, run_components
from rtcf_controllers.forward_command_controller import (
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)


@dataclass
class Float64MultiArray:
    data: list[float] = field(default_factory=list)


@pytest.fixture(autouse=True)
def fake_std_msgs(monkeypatch: pytest.MonkeyPatch) -> None:
    module = types.ModuleType("std_msgs.msg")
    module.Float64MultiArray = Float64MultiArray  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "std_msgs", types.ModuleType("std_msgs"))
    monkeypatch.setitem(sys.modules, "std_msgs.msg", module)


JOINTS = ["j1", "j2"]
LIMITS = {"j1": {"has_position_limits": True, "min_position": -3.14, "max_position": 3.14,
                 "has_velocity_limits": True, "max_velocity": 2.0,
                 "has_effort_limits": True, "max_effort": 10.0}}


def _run(cls: type[ForwardCommandController], *commands: list[float]) -> Trace:
    spec = rtcf.ComponentSpec("forward", cls, params={"joints": JOINTS,
                                                      "joint_limits": LIMITS})
    fed = [Float64MultiArray(list(c)) for c in commands]
    return run_components([spec], len(fed), frequency=100.0,
                          inputs={"/forward/commands": fed})


def _refusals(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]


@pytest.mark.parametrize(("cls", "bad", "why"), [
    (JointGroupPositionController, [4.2, 0.0],
     "position of j1 is 4.2, outside its limits [-3.14, 3.14] (joint_limits.j1)"),
    (JointGroupPositionController, [0.0, math.inf], "position of j2 is inf (not finite)"),
    (JointGroupVelocityController, [-2.5, 99.0],
     "velocity of j1 is -2.5, outside its limits [-2.0, 2.0] (joint_limits.j1)"),
    (JointGroupEffortController, [10.5, 0.0],
     "effort of j1 is 10.5, outside its limits [-10.0, 10.0] (joint_limits.j1)"),
    (JointGroupEffortController, [1e300, 0.0],
     "effort of j1 is 1e+300, outside its limits [-10.0, 10.0] (joint_limits.j1)"),
])
def test_a_command_outside_the_limits_or_not_finite_is_refused_not_clamped(
    cls: type[ForwardCommandController], bad: list[float], why: str,
    caplog: pytest.LogCaptureFixture,
) -> None:
    with caplog.at_level(logging.WARNING):
        trace = _run(cls, [1.0, 1.0], bad, bad)
    port = f"/{cls.fixed_interface}_command"
    assert [c.tolist() for c in trace.outputs[port]] == [[1.0, 1.0]] * 3  # the last stays
    assert _refusals(caplog) == [
        f"/forward/commands refused: {why}; the last command stays"]  # 1 a second
    assert trace.components["/forward"].refused_messages == {"~/commands": 2}


def test_within_the_limits_and_joints_without_them_are_taken() -> None:
    trace = _run(JointGroupPositionController, [3.14, 1e300], [-3.14, -5.0])
    assert [c.tolist() for c in trace.outputs["/position_command"]] == [
        [3.14, 1e300], [-3.14, -5.0]]  # j2 has no limits: any finite value
    assert trace.components["/forward"].refused_messages == {"~/commands": 0}


def test_limits_that_cannot_be_are_refused_at_configure() -> None:
    spec = rtcf.ComponentSpec("forward", JointGroupPositionController, params={
        "joints": JOINTS, "joint_limits": {"j2": {"has_position_limits": True,
                                                  "min_position": 1.0, "max_position": 0.0}}})
    with pytest.raises(rtcf.RtcfError, match=r"'joint_limits\.j2\.min_position' is 1\.0"):
        run_components([spec], 1)
