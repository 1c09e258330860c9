"""The runner parameter ``lanes``: its forms, its errors, and the default placement."""

import pytest

from rtcf._core._errors import ConfigurationError
from rtcf._core._settings import RunnerSettings, lane_placement, parse_lanes


def test_the_text_form_gives_cpus_and_priorities():
    assert parse_lanes("mpc:0:70, left_arm:1; spare") == {
        "mpc": (0, 70), "left_arm": (1, None), "spare": (None, None)
    }


def test_a_mapping_from_yaml_is_the_same_as_its_text():
    s = RunnerSettings.from_params({"lanes": {"mpc": {"cpu": 0, "priority": 70}, "arm": 1}})
    assert parse_lanes(s.lanes) == {"mpc": (0, 70), "arm": (1, None)}


@pytest.mark.parametrize(
    ("text", "says"),
    [("mpc:x", "integers"), ("mpc:0:120", "out of range"), (":0", "name:cpu"),
     ("a:1:2:3", "name:cpu"), ("mpc:-1", "from 0")],
)
def test_a_bad_lanes_parameter_is_one_error_naming_it(text, says):
    with pytest.raises(ConfigurationError, match=f"lanes {text!r}.*{says}"):
        RunnerSettings.from_params({"lanes": text})


def test_each_lane_gets_a_cpu_of_its_own_beside_the_main_lanes():
    settings = RunnerSettings(cpu_affinity_mask=0b0010)  # main on CPU 1
    placed = lane_placement(settings, ["a", "b", "c"], [0, 1, 2, 3])
    assert {k: v[0] for k, v in placed.items()} == {"a": 1 << 3, "b": 1 << 2, "c": 1 << 0}
    assert all(v[1] == settings.priority for v in placed.values())


def test_a_lane_without_a_cpu_left_is_not_pinned_and_says_so():
    settings = RunnerSettings(cpu_affinity_mask=0b10)
    placed = lane_placement(settings, ["a", "b"], [0, 1])
    assert placed["a"][0] == 1 << 0
    assert placed["b"][0] == 0 and "not pinned" in placed["b"][2]


def test_the_lanes_parameter_wins_and_its_cpus_are_not_given_twice():
    settings = RunnerSettings(lanes="b:0:60")
    placed = lane_placement(settings, ["a", "b"], [0, 1])
    assert placed["b"] == (1 << 0, 60, "CPU 0 (the lanes parameter)")
    assert placed["a"][0] == 1 << 1
