"""The hardware interface API (rtcf._core._hardware, _hardware_layout) and plugins by
name (_hardware_plugins): exports per hardware type, the values' layout, initial values
per data type, the arrays' contract, accessors and views; entry points."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import rtcf
from rtcf import CallbackReturn, ConfigurationError
from rtcf._core._generic_system import GenericSystem
from rtcf._core._hardware import InterfaceNotFoundError
from rtcf._core._hardware_layout import describe
from rtcf._core._hardware_plugins import BUILTIN, GROUP, hardware_plugins, load_hardware_class
from rtcf._core._robot_description import parse

from .test_generic_system import HEAD, TAIL

ROOT = Path(__file__).resolve().parents[2]


def tag(kind: str, body: str, plugin: str = "mock_components/GenericSystem") -> str:
    return (f'<ros2_control name="hw" type="{kind}"><hardware><plugin>{plugin}</plugin>'
            f"</hardware>{body}</ros2_control>")


BODY = ('<joint name="joint1"><command_interface name="position"/>'
        '<command_interface name="velocity"/><state_interface name="position"/>'
        '<state_interface name="velocity"/></joint>'
        '<joint name="joint2"><command_interface name="position"/>'
        '<state_interface name="position"><param name="initial_value">0.5</param>'
        '</state_interface><state_interface name="effort"/></joint>'
        '<sensor name="ft"><state_interface name="fx"/><state_interface name="fy"/></sensor>'
        '<gpio name="io"><command_interface name="out" data_type="bool"/>'
        '<state_interface name="out" data_type="bool"/>'
        '<state_interface name="code" data_type="uint8"/>'
        '<state_interface name="f" data_type="float32"><param name="initial_value">0.1</param>'
        "</state_interface></gpio>")


class Plain(rtcf.SystemInterface):
    def read(self, time: float, period: float) -> None:
        self.joint_states("position")[:] = self.joint_commands("position")


class WithExtras(Plain):
    def export_unlisted_state_interface_descriptions(self) -> list:  # type: ignore[type-arg]
        return [describe("motor", "temperature", initial_value="20")]

    def export_unlisted_command_interface_descriptions(self) -> list:  # type: ignore[type-arg]
        return [describe("motor", "enable", data_type="bool")]


class PlainSensor(rtcf.SensorInterface):
    def read(self, time: float, period: float) -> None:
        pass


class PlainActuator(rtcf.ActuatorInterface):
    def read(self, time: float, period: float) -> None:
        pass


def built(cls: type, kind: str = "system", body: str = BODY) -> rtcf.SystemInterface:
    [info] = parse(HEAD + tag(kind, body) + TAIL)
    hw = cls()
    assert hw.init(info) in (None, CallbackReturn.SUCCESS)
    hw.bind_values()
    return hw


def test_a_system_exports_joints_sensors_and_gpios_grouped_by_interface() -> None:
    hw = built(Plain)
    assert hw.state_names == ("joint1/position", "joint2/position", "joint1/velocity",
                              "joint2/effort", "ft/fx", "ft/fy", "io/out", "io/code", "io/f")
    assert hw.command_names == ("joint1/position", "joint2/position", "joint1/velocity",
                                "io/out")
    assert hw.joints_with_state("position") == ("joint1", "joint2")
    assert hw.joints_with_state("effort") == ("joint2",)
    assert hw.joints_with_state("torque") == ()


def test_actuators_and_sensors_export_what_ros2_control_gives_their_types() -> None:
    body = BODY.split("<sensor")[0]
    actuator = built(PlainActuator, "actuator", body)
    assert set(actuator.command_names) == {"joint1/position", "joint1/velocity",
                                           "joint2/position"}
    sensor = built(PlainSensor, "sensor", '<sensor name="ft"><state_interface name="fx"/>'
                                          "</sensor>")
    assert (sensor.state_names, sensor.command_names) == (("ft/fx",), ())


def test_initial_values_per_data_type() -> None:
    hw = built(Plain)
    values = dict(zip(hw.state_names, hw.states.tolist(), strict=True))
    assert values["joint2/position"] == 0.5
    assert math.isnan(values["joint1/position"]) and math.isnan(values["ft/fx"])
    assert values["io/out"] == 0.0  # bool: false
    assert values["io/code"] == 255.0  # uint8: its largest value
    assert values["io/f"] == float(np.float32(0.1))
    assert all(math.isnan(v) for v in hw.commands[:3])


@pytest.mark.parametrize("body,message", [
    ('<state_interface name="x"><param name="initial_value">abc</param></state_interface>',
     "Invalid initial value : 'abc' parsed for interface : 'io/x' with type : 'double'"),
    ('<state_interface name="x" data_type="int8"><param name="initial_value">300</param>'
     "</state_interface>", "Invalid initial value : '300' parsed for interface : 'io/x'"),
    ('<state_interface name="x" data_type="bool"><param name="initial_value">yes</param>'
     "</state_interface>", "with type : 'bool'"),
    ('<state_interface name="x" data_type="complex"/>',
     "Invalid data type: 'complex' for interface: io/x. Check supported types"),
])
def test_invalid_initial_values_and_types(body: str, message: str) -> None:
    with pytest.raises(ConfigurationError, match=message.replace("(", "\\(")):
        built(Plain, body=f'<gpio name="io">{body}</gpio>')


def test_views_are_slices_of_the_arrays() -> None:
    hw = built(Plain)
    positions = hw.joint_states("position")
    assert np.shares_memory(positions, hw.states) and positions.shape == (2,)
    hw.joint_commands("position")[:] = [1.0, 2.0]
    hw.read(0.0, 0.01)
    assert (hw.get_state("joint1/position"), hw.get_state("joint2/position")) == (1.0, 2.0)
    hw.sensor_states("ft")[:] = [3.0, 4.0]
    assert hw.get_state("ft/fy") == 4.0
    hw.gpio_commands("io")[0] = 1.0
    assert hw.get_command("io/out") == 1.0
    assert hw.gpio_states("io").shape == (3,)
    with pytest.raises(InterfaceNotFoundError, match="no joint state interfaces for 'torque' "
                                                     "\\(it has: effort, position, velocity\\)"):
        hw.joint_states("torque")


def test_accessors_by_name_and_their_errors() -> None:
    hw = built(Plain)
    hw.set_command("joint1/velocity", 0.25)
    hw.set_state("joint2/effort", -1.5)
    assert hw.get_command("joint1/velocity") == 0.25 and hw.get_state("joint2/effort") == -1.5
    assert hw.has_state("ft/fx") and not hw.has_command("ft/fx")
    with pytest.raises(InterfaceNotFoundError) as missing:
        hw.get_state("joint9/position")
    assert str(missing.value) == ("The requested state interface not found: 'joint9/position' "
                                  "in hardware component: 'hw'.")
    assert isinstance(missing.value, LookupError)


def test_unlisted_interfaces_come_after_the_described_ones() -> None:
    hw = built(WithExtras)
    assert hw.state_names[-1] == "motor/temperature" and hw.get_state("motor/temperature") == 20
    assert hw.command_names[-1] == "motor/enable" and hw.get_command("motor/enable") == 0.0


def test_the_arrays_contract_views_of_a_bigger_buffer_kept_in_place() -> None:
    [info] = parse(HEAD + tag("system", BODY) + TAIL)
    hw = Plain()
    hw.init(info)
    states, _ = hw.export_interfaces()
    buffer = np.zeros(len(states) + 3)
    view = buffer[2:2 + len(states)]
    with pytest.raises(ValueError, match="must be a 1-D float64 numpy array of 9 values"):
        hw.bind_values(buffer, None)
    hw.bind_values(view, None)
    assert hw.states is view and buffer[2 + 1] == 0.5  # joint2/position, in place
    hw.set_state("joint1/position", 7.0)
    assert buffer[2] == 7.0


def test_values_before_they_exist_are_an_error_that_says_when() -> None:
    hw = Plain()
    with pytest.raises(RuntimeError, match="on_init has not run yet"):
        _ = hw.info
    [info] = parse(HEAD + tag("system", BODY) + TAIL)
    hw.init(info)
    with pytest.raises(RuntimeError, match="not exported yet"):
        hw.get_state("joint1/position")


# ---------------------------------------------------------------------- plugins


def test_builtin_plugins_are_declared_in_pyproject() -> None:
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert declared[GROUP] == BUILTIN
    assert "mock_components/GenericSystem" in hardware_plugins()
    [info] = parse(HEAD + tag("system", BODY) + TAIL)
    assert load_hardware_class(info) is GenericSystem


def test_a_package_adds_its_plugin_with_an_entry_point(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "my_robot_hw.py").write_text(
        "import rtcf\n"
        "class MyRobot(rtcf.SystemInterface):\n"
        "    def read(self, time, period):\n"
        "        return rtcf.ReturnType.OK\n")
    dist = tmp_path / "my_robot_hw-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my-robot-hw\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(f"[{GROUP}]\nmy_robot/MyRobot = my_robot_hw:MyRobot\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "my_robot_hw", raising=False)
    [info] = parse(HEAD + tag("system", BODY, "my_robot/MyRobot") + TAIL)
    cls = load_hardware_class(info)
    assert cls.__name__ == "MyRobot" and "my_robot/MyRobot" in hardware_plugins()


@pytest.mark.parametrize("plugin", [f"{__name__}:Plain", f"{__name__}.Plain"])
def test_a_class_named_directly(plugin: str) -> None:
    [info] = parse(HEAD + tag("system", BODY, plugin) + TAIL)
    assert load_hardware_class(info) is Plain


def test_a_missing_plugin_says_what_to_do_and_what_there_is() -> None:
    [info] = parse(HEAD + tag("system", BODY, "my_robot/Missing") + TAIL)
    with pytest.raises(ConfigurationError) as missing:
        load_hardware_class(info)
    text = str(missing.value)
    assert "\n" not in text
    assert text.startswith(
        "hardware 'hw' (<plugin>my_robot/Missing</plugin>): According to the loaded plugin "
        "descriptions the class my_robot/Missing with base class type "
        "hardware_interface::SystemInterface does not exist. Declared types are ")
    assert "mock_components/GenericSystem" in text
    assert f"entry point group '{GROUP}'" in text and "module:Class" in text


@pytest.mark.parametrize("plugin,kind,message", [
    (f"{__name__}:PlainSensor", "system", "is a sensor interface, but the <ros2_control> tag's "
                                          "type is 'system'"),
    (f"{__name__}:BODY", "system", "is not a hardware interface"),
    ("no_such_module_here:X", "system", "cannot import module 'no_such_module_here'"),
    (f"{__name__}:Nope", "system", "has no class 'Nope'"),
])
def test_a_plugin_of_the_wrong_kind(plugin: str, kind: str, message: str) -> None:
    [info] = parse(HEAD + tag(kind, BODY.split("<sensor")[0], plugin) + TAIL)
    with pytest.raises(ConfigurationError, match=message):
        load_hardware_class(info)
