"""rtcf_controllers._limits: ros2_control's joint_limits parameters, read once and
checked at configure; the refusal text a controller logs."""

from __future__ import annotations

import math

import pytest

import rtcf
from rtcf.testing import run_components
from rtcf_controllers._limits import JointLimits, read_limits
from rtcf_controllers._params import ControllerParameters


class Reads(rtcf.Component):
    def configure(self) -> None:
        self.limits = read_limits(ControllerParameters(self), ["j1", "j2", "j3"])


def _read(params: dict) -> JointLimits:
    trace = run_components([rtcf.ComponentSpec("c", Reads, params=params)], 1)
    return trace.components["/c"].limits  # type: ignore[attr-defined]


def test_limits_count_only_where_their_has_flag_is_true() -> None:
    limits = _read({"joint_limits": {
        "j1": {"has_position_limits": True, "min_position": -3.14, "max_position": 3.14,
               "has_velocity_limits": True, "max_velocity": 2},
        "j2": {"has_position_limits": False, "min_position": 0.0, "max_position": 1.0,
               "has_effort_limits": True, "max_effort": 10.0},
    }, "joint_limits.j3.has_position_limits": True, "joint_limits.j3.min_position": 0,
        "joint_limits.j3.max_position": 0})
    assert limits.position == {"j1": (-3.14, 3.14), "j3": (0.0, 0.0)}
    assert limits.velocity == {"j1": 2.0} and limits.effort == {"j2": 10.0}
    assert _read({}) == JointLimits({}, {}, {})


@pytest.mark.parametrize(("j1", "words"), [
    ({"has_position_limits": True, "min_position": 1.0, "max_position": -1.0},
     "'joint_limits.j1.min_position' is 1.0; give a number <= joint_limits.j1.max_position -1.0"),
    ({"has_position_limits": True, "min_position": -math.inf, "max_position": 1.0},
     "'joint_limits.j1.min_position' is -inf; give a finite number"),
    ({"has_position_limits": True, "min_position": 0.0, "max_position": math.nan},
     "'joint_limits.j1.max_position' is nan; give a number (not NaN)"),
    ({"has_position_limits": True, "max_position": 1.0},
     "'joint_limits.j1.min_position' is None; give a number"),
    ({"has_velocity_limits": True, "max_velocity": -1.0},
     "'joint_limits.j1.max_velocity' is -1.0; give a number >= 0"),
    ({"has_effort_limits": True, "max_effort": math.inf},
     "'joint_limits.j1.max_effort' is inf; give a finite number"),
])
def test_a_limit_that_cannot_be_is_a_configuration_error_naming_it(j1: dict, words: str) -> None:
    with pytest.raises(rtcf.RtcfError) as caught:
        _read({"joint_limits": {"j1": j1}})
    assert words in str(caught.value)


def test_outside_says_the_value_the_limits_and_the_parameters() -> None:
    limits = JointLimits({"j1": (-3.14, 3.14)}, {"j1": 2.0}, {"j2": 10.0})
    assert limits.outside("j1", "position", 4.2) == (
        "4.2, outside its limits [-3.14, 3.14] (joint_limits.j1)")
    assert limits.outside("j1", "position", 3.14) is None
    assert limits.outside("j1", "velocity", -2.5) == (
        "-2.5, outside its limits [-2.0, 2.0] (joint_limits.j1)")
    assert limits.outside("j2", "effort", 9.0) is None
    assert limits.outside("j2", "position", 1e300) is None  # j2: no position limits
