"""rtcf_controllers._params: a ros2_controllers YAML section read as the controllers name it."""

from __future__ import annotations

import math

import pytest

import rtcf
from rtcf.testing import run_components
from rtcf_controllers._params import ControllerParameters


class Reads(rtcf.Component):
    """Reads every kind once in configure and keeps what it got."""

    def configure(self) -> None:
        p = ControllerParameters(self)
        self.got = {
            "goal_time": p.number("constraints.goal_time", 0.0),
            "p": p.number("gains.j1.p", 0.0),
            "dotted": p.number("gains.j2.p", 0.0),
            "limit": p.number("linear.x.max_velocity", math.nan, nan=True),
            "joints": p.names("joints", [], non_empty=True),
            "rate": p.integer("rate", 50),
            "tf": p.flag("enable_odom_tf", True),
            "method": p.text("interpolation_method", "splines", choices=("splines", "none")),
            "cov": p.numbers("pose_covariance_diagonal", [0.0] * 6),
            "set": p.has("gains.j1.p"),
            "unset": p.has("gains.j3.p"),
        }


def _configured(params: dict) -> dict:
    trace = run_components([rtcf.ComponentSpec("c", Reads, params=params)], 1)
    return trace.components["/c"].got


def test_nested_and_dotted_names_are_both_found_and_defaults_fill_the_rest() -> None:
    got = _configured(
        {"joints": ["a", "b"], "constraints": {"goal_time": 2}, "gains": {"j1": {"p": 5.0}},
         "gains.j2.p": 7.0}
    )
    assert got["goal_time"] == 2.0 and isinstance(got["goal_time"], float)
    assert (got["p"], got["dotted"]) == (5.0, 7.0)
    assert math.isnan(got["limit"]) and got["joints"] == ["a", "b"]
    assert (got["rate"], got["tf"], got["method"]) == (50, True, "splines")
    assert got["cov"] == [0.0] * 6 and (got["set"], got["unset"]) == (True, False)


@pytest.mark.parametrize(
    ("params", "words"),
    [
        ({"joints": []}, "'joints' is []; give a list of at least one name"),
        ({"joints": ["a", "a"]}, "without duplicates"),
        ({"joints": ["a"], "constraints": {"goal_time": "x"}}, "'constraints.goal_time' is 'x'"),
        ({"joints": ["a"], "interpolation_method": "cubic"}, "one of 'splines', 'none'"),
        ({"joints": ["a"], "enable_odom_tf": 1}, "true or false"),
    ],
)
def test_a_wrong_value_names_the_component_the_parameter_and_what_to_give(
    params: dict, words: str
) -> None:
    with pytest.raises(rtcf.RtcfError) as caught:
        _configured(params)
    message = str(caught.value)
    assert "'/c'" in message
    assert words in message
