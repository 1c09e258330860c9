"""mock_components/GenericSystem (rtcf._core._generic_system) through the resource
manager, as ros2_control Jazzy's test_generic_system.cpp drives the C++ one: the same
URDF snippets, the same sequences of commands, read() and write(), the same values."""

from __future__ import annotations

import math

import pytest

from rtcf._core._lifecycle import ACTIVE, INACTIVE, UNCONFIGURED
from rtcf._core._resource_manager import ResourceManager

PERIOD = 0.1
NAN = math.nan
INF = math.inf

# ros2_control_test_assets' urdf_head (joints 1-3 revolute) and urdf_head_mimic (joint2
# mimics joint1 with multiplier -2), without the visuals
_LINKS = "".join(f'<link name="{n}"/>' for n in ("world", "base_link", "link1", "link2",
                                                  "link3", "tool_link"))


def _joint(name: str, parent: str, child: str, extra: str = "") -> str:
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/>{extra}<limit effort="0.1" lower="-3.14159265359" '
            'upper="3.14159265359" velocity="0.2"/></joint>')


_FIXED = ('<joint name="base_joint" type="fixed"><parent link="world"/><child link="base_link"/>'
          '</joint><joint name="tool_joint" type="fixed"><parent link="link2"/>'
          '<child link="tool_link"/></joint>')
HEAD = ('<?xml version="1.0" encoding="utf-8"?><robot name="MinimalRobot">' + _LINKS + _FIXED
        + _joint("joint1", "base_link", "link1") + _joint("joint2", "link1", "link2")
        + _joint("joint3", "link2", "link3"))
HEAD_MIMIC = ('<?xml version="1.0" encoding="utf-8"?><robot name="MinimalRobot">' + _LINKS
              + _FIXED + _joint("joint1", "base_link", "link1")
              + _joint("joint2", "link1", "link2",
                       '<mimic joint="joint1" multiplier="-2" offset="0"/>')
              + _joint("joint3", "link2", "link3"))
TAIL = "</robot>"


def hardware(body: str, *params: tuple[str, str], name: str = "MockHardwareSystem",
             group: str = "") -> str:
    extra = f"<group>{group}</group>" if group else ""
    extra += "".join(f'<param name="{k}">{v}</param>' for k, v in params)
    return (f'<ros2_control name="{name}" type="system"><hardware>'
            f"<plugin>mock_components/GenericSystem</plugin>{extra}</hardware>{body}"
            "</ros2_control>")


def joint(name: str, commands: tuple[str, ...], states: dict[str, str | None],
          attrs: str = "") -> str:
    body = "".join(f'<command_interface name="{c}"/>' for c in commands)
    for state, initial in states.items():
        value = "" if initial is None else f'<param name="initial_value">{initial}</param>'
        body += f'<state_interface name="{state}">{value}</state_interface>'
    return f'<joint name="{name}"{attrs}>{body}</joint>'


PV = ("position", "velocity")
HW_2DOF = hardware(joint("joint1", ("position",), {"position": "1.57"})
                   + joint("joint2", ("position",), {"position": "0.7854"}))
HW_2DOF_ASYMMETRIC = hardware(joint("joint1", ("position",), {"velocity": "1.57"})
                              + joint("joint2", ("acceleration",), {"position": "0.7854"}))
STANDARD_JOINTS = (joint("joint1", PV, {"position": "3.45", "velocity": "0.0"})
                   + joint("joint2", PV, {"position": "2.78", "velocity": "0.0"}))
HW_STANDARD = hardware(STANDARD_JOINTS, group="Hardware Group")
HW_WITH_GPIO = hardware(
    joint("joint1", PV, {"position": "1.55", "velocity": "0.1"})
    + joint("joint2", PV, {"position": "0.65", "velocity": "0.2"})
    + '<gpio name="voltage_output"><command_interface name="voltage"/>'
      '<state_interface name="voltage"><param name="initial_value">0.5</param>'
      "</state_interface></gpio>", group="Hardware Group")
SENSOR = ('<sensor name="tcp_force_sensor"><state_interface name="fx"/>'
          '<state_interface name="fy"/><state_interface name="tx"/><state_interface name="ty"/>'
          '<param name="frame_id">kuka_tcp</param></sensor>')
PLAIN_JOINTS = (joint("joint1", PV, {"position": None, "velocity": None})
                + joint("joint2", PV, {"position": None, "velocity": None}))
HW_WITH_SENSOR = hardware(PLAIN_JOINTS + SENSOR)
HW_MIMIC = hardware(joint("joint1", PV, {"position": "1.57", "velocity": None})
                    + joint("joint2", (), {"position": None, "velocity": None},
                            ' mimic="true"'))
OFFSET = ("position_state_following_offset", "-3")
CUSTOM = ("custom_interface_with_following_offset", "actual_position")
HW_OFFSET = hardware(STANDARD_JOINTS, OFFSET)
HW_CUSTOM_MISSING = hardware(STANDARD_JOINTS, OFFSET, CUSTOM, group="Hardware Group")
HW_CUSTOM = hardware(
    joint("joint1", PV, {"position": "3.45", "velocity": "0.0", "actual_position": None})
    + joint("joint2", PV, {"position": "2.78", "velocity": "0.0", "actual_position": None}),
    OFFSET, CUSTOM)
GPIOS = ('<gpio name="flange_analog_IOs"><command_interface name="analog_output1" '
         'data_type="double"/><state_interface name="analog_output1"/>'
         '<state_interface name="analog_input1"/><state_interface name="analog_input2"/></gpio>'
         '<gpio name="flange_vacuum"><command_interface name="vacuum"/>'
         '<state_interface name="vacuum" data_type="double"/></gpio>')
GPIOS_BOOL = GPIOS.replace('<command_interface name="vacuum"/><state_interface name="vacuum" '
                           'data_type="double"/>', '<command_interface name="vacuum" '
                           'data_type="bool"/><state_interface name="vacuum" data_type="bool"/>')
HW_ROBOT_GPIO = hardware(STANDARD_JOINTS + GPIOS, ("example_param_write_for_sec", "2"),
                         ("example_param_read_for_sec", "2"), group="Hardware Group")
HW_GPIO_MOCK = hardware(STANDARD_JOINTS + GPIOS, ("mock_gpio_commands", "true"))
HW_GPIO_BOOL_MOCK = hardware(STANDARD_JOINTS + GPIOS_BOOL, ("mock_gpio_commands", "true"))
HW_GPIO_MOCK_TRUE = hardware(STANDARD_JOINTS + GPIOS, ("mock_gpio_commands", "True"))
HW_SENSOR_INITIAL = hardware(
    '<sensor name="force_sensor">' + "".join(
        f'<state_interface name="force.{a}"><param name="initial_value">0.0</param>'
        "</state_interface>" for a in "xyz") + "</sensor>")
HW_GPIO_INITIAL = hardware('<gpio name="sample_io"><state_interface name="output_1">'
                           '<param name="initial_value">1</param></state_interface></gpio>')
DYN = ("calculate_dynamics", "true")
PVA_STATES = {"position": "3.45", "velocity": None, "acceleration": None}
VACUUM = ('<gpio name="flange_vacuum"><command_interface name="vacuum"/>'
          '<state_interface name="vacuum" data_type="double"/></gpio>')
HW_DYN_MODES = hardware(
    joint("joint1", ("position", "velocity", "effort"), PVA_STATES)
    + joint("joint2", ("velocity", "acceleration"), {**PVA_STATES, "position": "2.78"}) + VACUUM,
    DYN)
HW_DYN_POSITION = hardware(joint("joint1", ("position",), {"position": "3.45"})
                           + joint("joint2", ("position",), {"position": "2.78"}), DYN)
HW_DYN_POSITION_OFFSET = hardware(joint("joint1", ("position",), {"position": "3.45"})
                                  + joint("joint2", ("position",), {"position": "2.78"}),
                                  OFFSET, DYN)
HW_DYN_VELOCITY = hardware(joint("joint1", ("velocity",), {"position": "3.45"})
                           + joint("joint2", ("velocity",), {"position": "2.78"}), DYN)
HW_DYN_VELOCITY_OFFSET = hardware(joint("joint1", ("velocity",), {"position": "3.45"})
                                  + joint("joint2", ("velocity",), {"position": "2.78"}),
                                  OFFSET, DYN)
HW_3DOF_DYN = hardware(
    joint("joint1", ("position",), PVA_STATES)
    + joint("joint2", ("velocity",), {**PVA_STATES, "position": "2.78"})
    + joint("joint3", ("acceleration",), {**PVA_STATES, "position": "2.78"}) + VACUUM, DYN)
HW_DISABLED = hardware(joint("joint1", PV, {"position": "3.45", "velocity": None}),
                       ("disable_commands", "True"))
NAME = "MockHardwareSystem"


def manager(*snippets: str, head: str = HEAD, rate: int = 100) -> ResourceManager:
    return ResourceManager.from_urdf(head + "".join(snippets) + TAIL, rate)


def active(*snippets: str, head: str = HEAD) -> ResourceManager:
    rm = manager(*snippets, head=head)
    assert rm.set_hardware_component_state(NAME, ACTIVE).ok
    return rm


def state(rm: ResourceManager, key: str) -> float:
    return float(rm.states[rm.state_index[key]])


def command(rm: ResourceManager, key: str) -> float:
    return float(rm.commands[rm.command_index[key]])


def set_commands(rm: ResourceManager, **values: float) -> None:
    for key, value in values.items():
        rm.commands[rm.command_index[key.replace("__", "/")]] = value


def states_of(rm: ResourceManager, *keys: str) -> list[float]:
    return [state(rm, k) for k in keys]


def is_nan(value: float) -> bool:
    return math.isnan(value)


def read(rm: ResourceManager) -> None:
    assert rm.read_all(0.0, PERIOD).result == 0


def write(rm: ResourceManager) -> None:
    assert rm.write_all(0.0, PERIOD).result == 0


# ------------------------------------------------------------------ the interfaces


def test_symmetric_interfaces_and_initial_values() -> None:
    rm = active(HW_2DOF)
    assert sorted(rm.state_keys) == ["joint1/position", "joint2/position"]
    assert sorted(rm.command_keys) == ["joint1/position", "joint2/position"]
    assert states_of(rm, "joint1/position", "joint2/position") == [1.57, 0.7854]
    assert is_nan(command(rm, "joint1/position")) and is_nan(command(rm, "joint2/position"))


def test_asymmetric_interfaces() -> None:
    rm = active(HW_2DOF_ASYMMETRIC)
    assert set(rm.state_keys) == {"joint1/velocity", "joint2/position"}
    assert set(rm.command_keys) == {"joint1/position", "joint2/acceleration"}
    assert not rm.state_interface_exists("joint1/position")
    assert not rm.command_interface_exists("joint2/position")
    # a claim of what is not exported is refused; of what is, granted
    with pytest.raises(Exception, match="'joint2/position' is not available"):
        rm.claims.claim("c", ["joint2/position"])
    rm.claims.claim("c", ["joint1/position", "joint2/acceleration"])
    assert state(rm, "joint1/velocity") == 1.57 and state(rm, "joint2/position") == 0.7854
    assert is_nan(command(rm, "joint1/position")) and is_nan(command(rm, "joint2/acceleration"))


def functional(snippet: str, offset: float = 0.0) -> None:
    """Jazzy's generic_system_functional_test."""
    rm = manager(snippet)
    [info] = rm.list_hardware_components()
    assert (info.state.label, info.rw_rate) == ("unconfigured", 100)
    assert rm.set_hardware_component_state(NAME, INACTIVE).state.label == "inactive"
    assert rm.set_hardware_component_state(NAME, ACTIVE).state.label == "active"
    keys = ("joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity")
    initial = [3.45 + offset, 0.0, 2.78 + offset, 0.0]
    assert states_of(rm, *keys) == initial
    assert all(is_nan(command(rm, k)) for k in keys)
    read(rm)  # no command yet (NaN): nothing changes
    write(rm)
    assert states_of(rm, *keys) == initial
    set_commands(rm, joint1__position=0.11, joint1__velocity=0.22, joint2__position=0.33,
                 joint2__velocity=0.44)
    write(rm)  # write() changes nothing
    assert states_of(rm, *keys) == initial
    read(rm)  # read() mirrors the commands (+ the offset on positions)
    assert states_of(rm, *keys) == [0.11 + offset, 0.22, 0.33 + offset, 0.44]
    assert [command(rm, k) for k in keys] == [0.11, 0.22, 0.33, 0.44]
    set_commands(rm, joint1__position=0.55, joint1__velocity=0.66, joint2__position=0.77,
                 joint2__velocity=0.88)
    assert states_of(rm, *keys) == [0.11 + offset, 0.22, 0.33 + offset, 0.44]
    assert rm.set_hardware_component_state(NAME, INACTIVE).state.label == "inactive"


def test_functionality() -> None:
    functional(HW_STANDARD)


def test_functionality_with_offset() -> None:
    functional(HW_OFFSET, -3.0)


def test_offset_on_a_custom_interface_that_does_not_exist_is_not_applied() -> None:
    functional(HW_CUSTOM_MISSING, 0.0)


def test_offset_on_a_custom_interface() -> None:
    rm = active(HW_CUSTOM)
    assert states_of(rm, "joint1/position", "joint2/position") == [3.45, 2.78]
    set_commands(rm, joint1__position=0.11, joint1__velocity=0.22, joint2__position=0.33,
                 joint2__velocity=0.44)
    write(rm)
    assert states_of(rm, "joint1/position", "joint2/position") == [3.45, 2.78]
    read(rm)
    assert states_of(rm, "joint1/position", "joint1/actual_position", "joint1/velocity",
                     "joint2/position", "joint2/actual_position", "joint2/velocity") == [
        0.11, 0.11 - 3, 0.22, 0.33, 0.33 - 3, 0.44]


@pytest.mark.parametrize("same_group", [False, True])
def test_an_infinite_command_is_an_error_of_its_hardware_and_of_its_group(same_group: bool) -> None:
    groups = ("Hardware Group", "Hardware Group") if same_group else ("Group 1", "Group 2")
    rm = manager(*(hardware(joint(f"joint{i}", PV, {"position": p, "velocity": None}),
                            name=f"MockHardwareSystem{i}", group=g)
                   for i, p, g in ((1, "3.45", groups[0]), (2, "2.78", groups[1]))), rate=200)
    for name in ("MockHardwareSystem1", "MockHardwareSystem2"):
        info = {c.name: c for c in rm.list_hardware_components()}[name]
        assert (info.state.id, info.rw_rate) == (UNCONFIGURED, 200)
        assert rm.set_hardware_component_state(name, ACTIVE).ok
    keys = ("joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity")
    assert states_of(rm, *keys) == [3.45, 0.0, 2.78, 0.0]
    set_commands(rm, joint1__position=0.11, joint1__velocity=0.22, joint2__position=0.33,
                 joint2__velocity=0.44)
    write(rm)
    read(rm)
    assert states_of(rm, *keys) == [0.11, 0.22, 0.33, 0.44]
    set_commands(rm, joint1__position=INF, joint1__velocity=INF)
    status = rm.read_all(0.0, PERIOD)
    assert status.result == 1
    both = ["MockHardwareSystem1", "MockHardwareSystem2"]
    assert status.failed_hardware_names == (both if same_group else both[:1])
    for key in ("joint1/position", "joint1/velocity"):
        assert not rm.state_interface_is_available(key)
        assert not rm.command_interface_is_available(key)
    for key in ("joint2/position", "joint2/velocity"):
        assert rm.state_interface_is_available(key) is not same_group
        assert rm.command_interface_is_available(key) is not same_group
    # recoverable only by configuring and activating the failed hardware again
    set_commands(rm, joint1__position=0.0, joint1__velocity=0.0)
    assert rm.read_all(0.0, PERIOD).result == 1
    assert rm.set_hardware_component_state("MockHardwareSystem1", INACTIVE).ok
    assert rm.set_hardware_component_state("MockHardwareSystem1", ACTIVE).ok
    read(rm)
    for name in both:
        assert rm.set_hardware_component_state(name, INACTIVE).state.label == "inactive"


def test_other_interfaces_gpio_mirrored() -> None:
    rm = active(HW_WITH_GPIO)
    assert len(rm.state_keys) == 5 and len(rm.command_keys) == 5
    keys = ("joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity",
            "voltage_output/voltage")
    assert states_of(rm, *keys) == [1.55, 0.1, 0.65, 0.2, 0.5]
    assert is_nan(command(rm, "voltage_output/voltage"))
    set_commands(rm, joint1__position=0.11, joint2__position=0.33, voltage_output__voltage=0.99)
    write(rm)
    assert states_of(rm, *keys) == [1.55, 0.1, 0.65, 0.2, 0.5]
    read(rm)
    assert states_of(rm, *keys) == [0.11, 0.1, 0.33, 0.2, 0.99]


def test_sensor_states_are_not_commanded_without_mock_sensor_commands() -> None:
    rm = active(HW_WITH_SENSOR)
    assert len(rm.state_keys) == 8 and len(rm.command_keys) == 4
    sensors = [f"tcp_force_sensor/{i}" for i in ("fx", "fy", "tx", "ty")]
    assert not any(rm.command_interface_exists(k) for k in sensors)
    with pytest.raises(Exception, match="'tcp_force_sensor/fx' is not available"):
        rm.claims.claim("c", ["tcp_force_sensor/fx"])
    # joint states without an initial value are 0.0 (configure), sensor states NaN
    assert states_of(rm, "joint1/position", "joint1/velocity", "joint2/position",
                     "joint2/velocity") == [0.0, 0.0, 0.0, 0.0]
    assert all(is_nan(state(rm, k)) for k in sensors)
    set_commands(rm, joint1__position=0.11, joint2__position=0.33)
    write(rm)
    read(rm)
    assert states_of(rm, "joint1/position", "joint1/velocity", "joint2/position",
                     "joint2/velocity") == [0.11, 0.0, 0.33, 0.0]
    assert all(is_nan(state(rm, k)) for k in sensors)


@pytest.mark.parametrize("flag", ["true", "True"])
def test_mock_sensor_commands(flag: str) -> None:
    rm = active(hardware(PLAIN_JOINTS + SENSOR, ("mock_sensor_commands", flag)))
    sensors = [f"tcp_force_sensor/{i}" for i in ("fx", "fy", "tx", "ty")]
    assert len(rm.state_keys) == 8 and len(rm.command_keys) == 8
    assert all(rm.command_interface_exists(k) for k in sensors)
    rm.claims.claim("forward", sensors)
    assert all(is_nan(state(rm, k)) and is_nan(command(rm, k)) for k in sensors)
    for key, value in zip(sensors, (1.11, 2.22, 3.33, 4.44), strict=True):
        rm.commands[rm.command_index[key]] = value
    set_commands(rm, joint1__position=0.11, joint2__position=0.33)
    write(rm)
    assert all(is_nan(state(rm, k)) for k in sensors)
    read(rm)
    assert states_of(rm, *sensors) == [1.11, 2.22, 3.33, 4.44]
    assert states_of(rm, "joint1/position", "joint2/position") == [0.11, 0.33]


def test_mimic_joint_follows_with_multiplier_and_offset() -> None:
    rm = active(HW_MIMIC, head=HEAD_MIMIC)
    assert len(rm.state_keys) == 4
    assert set(rm.command_keys) == {"joint1/position", "joint1/velocity"}
    keys = ("joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity")
    assert states_of(rm, *keys) == [1.57, 0.0, 0.0, 0.0]
    set_commands(rm, joint1__position=0.11, joint1__velocity=0.05)
    write(rm)
    assert states_of(rm, *keys) == [1.57, 0.0, 0.0, 0.0]
    read(rm)
    assert states_of(rm, *keys) == [0.11, 0.05, -0.22, -0.1]


def test_mimic_offset_is_added_to_the_position() -> None:
    head = HEAD_MIMIC.replace('multiplier="-2" offset="0"', 'multiplier="0.5" offset="0.25"')
    rm = active(HW_MIMIC, head=head)
    set_commands(rm, joint1__position=1.0, joint1__velocity=2.0)
    read(rm)
    assert states_of(rm, "joint2/position", "joint2/velocity") == [0.75, 1.0]


def test_gpio_commands_mirrored() -> None:
    rm = manager(HW_ROBOT_GPIO)
    assert rm.set_hardware_component_state(NAME, INACTIVE).ok
    assert rm.set_hardware_component_state(NAME, ACTIVE).ok
    assert len(rm.state_keys) == 8 and len(rm.command_keys) == 6
    assert rm.command_interface_exists("flange_analog_IOs/analog_output1")
    assert not rm.command_interface_exists("flange_analog_IOs/analog_input1")
    out, vac = "flange_analog_IOs/analog_output1", "flange_vacuum/vacuum"
    assert all(is_nan(v) for v in (state(rm, out), state(rm, vac), command(rm, out),
                                   command(rm, vac)))
    set_commands(rm, flange_analog_IOs__analog_output1=0.111, flange_vacuum__vacuum=0.222)
    write(rm)
    assert is_nan(state(rm, out)) and is_nan(state(rm, vac))
    read(rm)
    assert states_of(rm, out, vac) == [0.111, 0.222]
    set_commands(rm, flange_analog_IOs__analog_output1=0.333, flange_vacuum__vacuum=0.444)
    assert states_of(rm, out, vac) == [0.111, 0.222]
    functional(HW_ROBOT_GPIO)


@pytest.mark.parametrize("snippet,is_bool", [(HW_GPIO_MOCK, False), (HW_GPIO_BOOL_MOCK, True),
                                             (HW_GPIO_MOCK_TRUE, False)])
def test_mock_gpio_commands(snippet: str, is_bool: bool) -> None:
    rm = active(snippet)
    analog = [f"flange_analog_IOs/{i}" for i in ("analog_output1", "analog_input1",
                                                  "analog_input2")]
    vac = "flange_vacuum/vacuum"
    assert len(rm.state_keys) == 8 and len(rm.command_keys) == 8
    assert all(rm.command_interface_exists(k) for k in (*analog, vac))
    assert all(is_nan(state(rm, k)) and is_nan(command(rm, k)) for k in analog)
    if is_bool:  # a bool starts false
        assert (state(rm, vac), command(rm, vac)) == (0.0, 0.0)
    else:
        assert is_nan(state(rm, vac)) and is_nan(command(rm, vac))
    for key, value in zip(analog, (0.11, 0.33, 1.11), strict=True):
        rm.commands[rm.command_index[key]] = value
    rm.commands[rm.command_index[vac]] = 1.0 if is_bool else 2.22
    write(rm)
    assert all(is_nan(state(rm, k)) for k in analog)
    read(rm)
    assert states_of(rm, *analog) == [0.11, 0.33, 1.11]
    assert state(rm, vac) == (1.0 if is_bool else 2.22)


def test_sensor_and_gpio_initial_values() -> None:
    rm = active(HW_SENSOR_INITIAL)
    assert sorted(rm.state_keys) == [f"force_sensor/force.{a}" for a in "xyz"]
    assert states_of(rm, *rm.state_keys) == [0.0, 0.0, 0.0]
    rm = active(HW_GPIO_INITIAL)
    assert rm.state_keys == ("sample_io/output_1",)
    assert state(rm, "sample_io/output_1") == 1.0


# ---------------------------------------------------------------------- NaN and inf


def test_a_nan_command_is_not_mirrored_and_an_infinite_position_is_ignored() -> None:
    rm = active(HW_STANDARD)
    set_commands(rm, joint1__position=0.5, joint1__velocity=0.25)
    read(rm)
    set_commands(rm, joint1__position=NAN, joint1__velocity=NAN)
    read(rm)
    assert states_of(rm, "joint1/position", "joint1/velocity") == [0.5, 0.25]
    # Jazzy mirrors a position command only if finite: an infinite one is not an error
    set_commands(rm, joint1__position=-INF)
    read(rm)
    assert state(rm, "joint1/position") == 0.5
    set_commands(rm, joint1__velocity=INF)
    assert rm.read_all(0.0, PERIOD).result == 1
    assert rm.list_hardware_components()[0].state.label == "unconfigured"


# ---------------------------------------------------------------------- dynamics


def test_dynamics_in_position_velocity_and_acceleration_modes() -> None:
    rm = active(HW_DYN_MODES)
    assert len(rm.state_keys) == 7 and len(rm.command_keys) == 6
    j1p, j2p = 3.45, 2.78
    s = ("joint1/position", "joint1/velocity", "joint1/acceleration", "joint2/position",
         "joint2/velocity", "joint2/acceleration")
    assert states_of(rm, *s) == [j1p, 0.0, 0.0, j2p, 0.0, 0.0]
    claims = rm.claims
    # a joint interface that does not exist; a joint without position, velocity or
    # acceleration; a joint with two of them: all refused
    assert not claims.prepare_command_mode_switch(["joint1/unknown", "joint2/acceleration"], [])
    assert not claims.prepare_command_mode_switch(["joint1/effort", "joint2/acceleration"], [])
    assert not claims.prepare_command_mode_switch(
        ["joint1/position", "joint2/velocity", "joint2/acceleration"], [])
    start = ["joint1/position", "joint2/acceleration", "flange_vacuum/vacuum"]
    assert claims.prepare_command_mode_switch(start, [])
    assert claims.perform_command_mode_switch(start, [])
    set_commands(rm, joint1__position=0.11, joint2__acceleration=3.5)
    write(rm)
    assert states_of(rm, *s) == [j1p, 0.0, 0.0, j2p, 0.0, 0.0]

    read(rm)
    assert state(rm, "joint1/position") == 0.11
    j1v = (0.11 - 3.45) / PERIOD
    assert state(rm, "joint1/velocity") == pytest.approx(j1v, abs=1e-4)
    assert state(rm, "joint1/acceleration") == pytest.approx(j1v / PERIOD, abs=1e-4)
    j2v = 3.5 * PERIOD
    j2p += j2v * PERIOD
    assert state(rm, "joint2/acceleration") == 3.5
    assert state(rm, "joint2/velocity") == pytest.approx(j2v, abs=1e-4)
    assert state(rm, "joint2/position") == pytest.approx(j2p, abs=1e-4)

    read(rm)
    assert state(rm, "joint1/position") == 0.11
    assert state(rm, "joint1/velocity") == 0.0
    assert state(rm, "joint1/acceleration") == pytest.approx(-j1v / PERIOD, abs=1e-4)
    j2v += 3.5 * PERIOD
    j2p += j2v * PERIOD
    assert state(rm, "joint2/velocity") == pytest.approx(j2v, abs=1e-4)
    assert state(rm, "joint2/position") == pytest.approx(j2p, abs=1e-4)

    read(rm)
    assert states_of(rm, "joint1/position", "joint1/velocity", "joint1/acceleration") == [
        0.11, 0.0, 0.0]
    j2v += 3.5 * PERIOD
    j2p += j2v * PERIOD
    assert state(rm, "joint2/velocity") == pytest.approx(j2v, abs=1e-4)
    assert state(rm, "joint2/position") == pytest.approx(j2p, abs=1e-4)

    assert claims.prepare_command_mode_switch(["joint1/velocity", "joint2/velocity"], [])
    assert claims.perform_command_mode_switch(["joint1/velocity", "joint2/velocity"], [])
    set_commands(rm, joint1__velocity=0.5, joint2__velocity=2.0)
    write(rm)
    assert state(rm, "joint2/acceleration") == 3.5
    read(rm)
    assert state(rm, "joint1/position") == pytest.approx(0.11 + 0.5 * PERIOD, abs=1e-4)
    assert state(rm, "joint1/velocity") == 0.5
    assert state(rm, "joint1/acceleration") == (0.5 - 0.0) / PERIOD
    assert state(rm, "joint2/position") == pytest.approx(j2p + 2.0 * PERIOD, abs=1e-4)
    assert state(rm, "joint2/velocity") == 2.0
    assert state(rm, "joint2/acceleration") == pytest.approx((2.0 - j2v) / PERIOD, abs=1e-4)
    read(rm)
    assert state(rm, "joint1/position") == pytest.approx(0.11 + 2 * 0.5 * PERIOD, abs=1e-4)
    assert states_of(rm, "joint1/velocity", "joint1/acceleration", "joint2/velocity",
                     "joint2/acceleration") == [0.5, 0.0, 2.0, 0.0]
    # the commands of the modes left are kept, not used
    assert (command(rm, "joint1/position"), command(rm, "joint2/acceleration")) == (0.11, 3.5)


@pytest.mark.parametrize("offset", [0.0, -3.0])
def test_dynamics_position_mode_with_position_state_only(offset: float) -> None:
    rm = active(HW_DYN_POSITION_OFFSET if offset else HW_DYN_POSITION)
    assert states_of(rm, "joint1/position", "joint2/position") == [3.45 + offset, 2.78 + offset]
    claims = rm.claims
    assert claims.prepare_command_mode_switch(["joint1/position", "joint2/position"], [])
    assert claims.perform_command_mode_switch(["joint1/position", "joint2/position"], [])
    set_commands(rm, joint1__position=0.11, joint2__position=3.5)
    write(rm)
    assert states_of(rm, "joint1/position", "joint2/position") == [3.45 + offset, 2.78 + offset]
    for _ in range(3):
        read(rm)
        assert states_of(rm, "joint1/position", "joint2/position") == [0.11 + offset,
                                                                       3.5 + offset]


@pytest.mark.parametrize("offset", [0.0, -3.0])
def test_dynamics_velocity_mode_integrates_positions(offset: float) -> None:
    rm = active(HW_DYN_VELOCITY_OFFSET if offset else HW_DYN_VELOCITY)
    assert states_of(rm, "joint1/position", "joint2/position") == [3.45 + offset, 2.78 + offset]
    claims = rm.claims
    assert claims.prepare_command_mode_switch(["joint1/velocity", "joint2/velocity"], [])
    assert claims.perform_command_mode_switch(["joint1/velocity", "joint2/velocity"], [])
    set_commands(rm, joint1__velocity=0.11, joint2__velocity=3.5)
    write(rm)
    for n in (1, 2, 3):
        read(rm)
        assert state(rm, "joint1/position") == pytest.approx(3.45 + 0.11 * n * PERIOD + offset,
                                                             abs=1e-4)
        assert state(rm, "joint2/position") == pytest.approx(2.78 + 3.5 * n * PERIOD + offset,
                                                             abs=1e-4)


def test_dynamics_velocity_mode_leaves_the_position_while_no_velocity_is_known() -> None:
    """Where rtcf differs from Jazzy (which adds the offset in every read here)."""
    rm = active(HW_DYN_VELOCITY_OFFSET)
    assert rm.claims.perform_command_mode_switch(["joint1/velocity"], [])
    read(rm)
    read(rm)
    assert state(rm, "joint1/position") == 3.45 - 3.0


def test_disabled_commands_change_no_state() -> None:
    rm = active(HW_DISABLED)
    assert states_of(rm, "joint1/position", "joint1/velocity") == [3.45, 0.0]
    set_commands(rm, joint1__position=0.11, joint1__velocity=0.2)
    write(rm)
    read(rm)
    assert states_of(rm, "joint1/position", "joint1/velocity") == [3.45, 0.0]
    assert command(rm, "joint1/position") == 0.11


ALL_EXAMPLES = [HW_2DOF, HW_2DOF_ASYMMETRIC, HW_STANDARD, HW_WITH_GPIO, HW_WITH_SENSOR,
                hardware(PLAIN_JOINTS + SENSOR, ("mock_sensor_commands", "true")),
                hardware(PLAIN_JOINTS + SENSOR, ("mock_sensor_commands", "True")),
                HW_MIMIC, HW_OFFSET, HW_CUSTOM, HW_CUSTOM_MISSING, HW_ROBOT_GPIO, HW_GPIO_MOCK,
                HW_GPIO_BOOL_MOCK, HW_GPIO_MOCK_TRUE, HW_SENSOR_INITIAL, HW_GPIO_INITIAL,
                HW_DYN_POSITION, HW_DYN_VELOCITY, HW_3DOF_DYN, HW_DISABLED]


@pytest.mark.parametrize("snippet", ALL_EXAMPLES)
def test_mode_switch_of_every_command_interface_accepted(snippet: str) -> None:
    rm = active(snippet, head=HEAD_MIMIC if snippet is HW_MIMIC else HEAD)
    keys = list(rm.command_keys)
    assert rm.claims.prepare_command_mode_switch(keys, [])
    assert rm.claims.perform_command_mode_switch(keys, [])


def test_mode_switch_of_two_modes_of_one_joint_refused_with_dynamics() -> None:
    rm = active(HW_DYN_MODES)
    keys = list(rm.command_keys)
    assert not rm.claims.prepare_command_mode_switch(keys, [])
    assert rm.claims.perform_command_mode_switch(keys, [])
