"""Runner settings: defaults, conversions from launch parameters, validation."""

from __future__ import annotations

import pytest

from rtcf import ConfigurationError, RunnerSettings


def test_defaults() -> None:
    s = RunnerSettings()
    assert (s.mode, s.num_components_expected, s.frequency, s.wait_policy) == (
        "no_wait", 0, 1.0, "absolute"
    )
    assert (s.ros_mapping_whitelist, s.ros_mapping_blacklist) == ("", "")
    assert (s.lock_memory, s.safe_heap_size_kB, s.safe_stack_size_kB) == (False, 0, 0)
    assert (s.cpu_affinity_mask, s.priority) == (0, 80)
    assert s.period_ns == 1_000_000_000


def test_every_parameter_from_params() -> None:
    s = RunnerSettings.from_params({
        "mode": "wait_for_components",
        "num_components_expected": 3,
        "frequency": 500,
        "wait_policy": "relative",
        "ros_mapping_whitelist": "/ros/.*",
        "ros_mapping_blacklist": "/ros/private/.*",
        "lock_memory": True,
        "safe_heap_size_kB": 1024,
        "safe_stack_size_kB": 64,
        "cpu_affinity_mask": 6,
        "priority": 90,
    })
    assert s == RunnerSettings(
        mode="wait_for_components",
        num_components_expected=3,
        frequency=500.0,
        wait_policy="relative",
        ros_mapping_whitelist="/ros/.*",
        ros_mapping_blacklist="/ros/private/.*",
        lock_memory=True,
        safe_heap_size_kB=1024,
        safe_stack_size_kB=64,
        cpu_affinity_mask=6,
        priority=90,
    )
    assert isinstance(s.frequency, float)
    assert s.period_ns == 2_000_000
    assert s.notes == []


@pytest.mark.parametrize("mask", ["02", "0x2", "0X2", " 2 ", 2, 2.0])
def test_cpu_affinity_mask_conversions(mask: object) -> None:
    assert RunnerSettings.from_params({"cpu_affinity_mask": mask}).cpu_affinity_mask == 2


def test_hex_mask_with_letters() -> None:
    assert RunnerSettings.from_params({"cpu_affinity_mask": "0xff"}).cpu_affinity_mask == 255


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("num_components_expected", 2.5, "an integer"),
        ("num_components_expected", True, "an integer"),
        ("cpu_affinity_mask", "zz", "an integer bit mask"),
        ("frequency", "fast", "a number"),
        ("frequency", False, "a number"),
        ("lock_memory", "maybe", "true or false"),
        ("lock_memory", 1.5, "true or false"),
        ("mode", 3, "a string"),
        ("ros_mapping_whitelist", 1, "a string (a regular expression)"),
        ("priority", None, "an integer"),
    ],
)
def test_bad_values_name_the_parameter(key: str, value: object, expected: str) -> None:
    params: dict[str, object] = {"mode": "no_wait", key: value}
    with pytest.raises(ConfigurationError) as info:
        RunnerSettings.from_params(params, where="rt_runner '/r'")
    assert str(info.value) == (
        f"rt_runner '/r': parameter {key!r} has value {value!r}, which is not {expected}"
    )


@pytest.mark.parametrize(
    ("value", "expected"),
    [(True, True), (False, False), ("true", True), ("False", False), ("1", True), ("0", False),
     (1, True), (0, False)],
)
def test_lock_memory_bool_conversion(value: object, expected: bool) -> None:
    assert RunnerSettings.from_params({"lock_memory": value}).lock_memory is expected


def test_numeric_string_is_an_integer() -> None:
    s = RunnerSettings.from_params({"mode": "wait_for_components", "num_components_expected": "3"})
    assert s.num_components_expected == 3


def test_frequency_from_string() -> None:
    assert RunnerSettings.from_params({"frequency": "250.5"}).frequency == 250.5


def test_invalid_regex_is_reported() -> None:
    with pytest.raises(ConfigurationError) as info:
        RunnerSettings.from_params({"ros_mapping_blacklist": "(unclosed"}, where="here")
    msg = str(info.value)
    assert msg.startswith("here: ros_mapping_blacklist '(unclosed'")
    assert "not a valid regular expression" in msg
    with pytest.raises(ConfigurationError, match="ros_mapping_whitelist"):
        RunnerSettings(ros_mapping_whitelist="[")


def test_wait_for_components_needs_num() -> None:
    with pytest.raises(ConfigurationError, match="needs num_components_expected"):
        RunnerSettings.from_params({"mode": "wait_for_components"})
    with pytest.raises(ConfigurationError, match="needs num_components_expected"):
        RunnerSettings(mode="wait_for_components", num_components_expected=0)
    assert RunnerSettings(mode="wait_for_components", num_components_expected=1)


def test_unknown_mode_lists_the_known_ones() -> None:
    with pytest.raises(ConfigurationError) as info:
        RunnerSettings.from_params({"mode": "sometimes"}, where="r")
    assert str(info.value) == (
        "r: mode 'sometimes' is unknown; use one of wait_for_components, no_wait, "
        "wait_for_trigger"
    )


def test_mode_is_case_insensitive_from_params() -> None:
    assert RunnerSettings.from_params({"mode": "WAIT_FOR_TRIGGER"}).mode == "wait_for_trigger"


def test_unknown_wait_policy() -> None:
    with pytest.raises(ConfigurationError, match="wait_policy 'sloppy' is unknown"):
        RunnerSettings.from_params({"wait_policy": "sloppy"})


def test_unknown_params_and_missing_defaults_are_noted() -> None:
    s = RunnerSettings.from_params({"freqency": 10, "use_sim_time": True}, where="rt_runner '/r'")
    assert len(s.notes) == 3
    assert s.notes[0].startswith("rt_runner '/r': unknown parameter 'freqency' ignored; known are ")
    assert "frequency" in s.notes[0] and "cpu_affinity_mask" in s.notes[0]
    assert s.notes[1] == "rt_runner '/r': no mode given, using 'no_wait'"
    assert s.notes[2] == "rt_runner '/r': no frequency given, using 1.0 Hz"
    assert not any("parameter 'use_sim_time'" in n for n in s.notes)
    assert s.frequency == 1.0 and s.use_sim_time is True


@pytest.mark.parametrize("priority", [0, 100, -1])
def test_priority_out_of_range(priority: int) -> None:
    with pytest.raises(ConfigurationError, match=f"priority {priority} is out of range"):
        RunnerSettings.from_params({"priority": priority})


@pytest.mark.parametrize("priority", [1, 99])
def test_priority_bounds_are_allowed(priority: int) -> None:
    assert RunnerSettings(priority=priority).priority == priority


@pytest.mark.parametrize("frequency", [0, -1, 1e6, float("nan"), float("inf")])
def test_infeasible_frequency(frequency: float) -> None:
    with pytest.raises(ConfigurationError, match="not feasible"):
        RunnerSettings(frequency=frequency)


@pytest.mark.parametrize("key", ["safe_heap_size_kB", "safe_stack_size_kB", "cpu_affinity_mask"])
def test_negative_sizes_and_mask(key: str) -> None:
    with pytest.raises(ConfigurationError, match=f"{key} must not be negative"):
        RunnerSettings.from_params({key: -1})


def test_maps_to_ros() -> None:
    s = RunnerSettings(ros_mapping_whitelist="/ros/.*", ros_mapping_blacklist=".*/private")
    assert s.maps_to_ros("/ros/x")
    assert not s.maps_to_ros("/ros/private")
    assert not s.maps_to_ros("/other/ros/x")  # full match
    assert not RunnerSettings().maps_to_ros("/anything")
    assert RunnerSettings(ros_mapping_whitelist=".*").maps_to_ros("/anything")
