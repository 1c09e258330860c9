"""A Cia402System's URDF parameters read once, in on_init: defaults, the bus, and each
wrong value as one line naming the parameter or the joint."""

from __future__ import annotations

import pytest

pytest.importorskip("canopen")

from rtcf._core._robot_description import parse
from rtcf_canopen import _cia402
from rtcf_canopen._config import SystemConfig


def _info(hardware: str = "", joint1: str = '<param name="node_id">2</param>',
          command: str = "position"):
    return parse(f"""<robot name="r"><link name="a"/><link name="b"/>
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
      <ros2_control name="drives" type="system">
        <hardware><plugin>rtcf_canopen/Cia402System</plugin>{hardware}</hardware>
        <joint name="j1">{joint1}<command_interface name="{command}"/>
          <state_interface name="position"/></joint>
      </ros2_control></robot>""")[0]


def test_defaults_are_a_robot_on_socketcan() -> None:
    c = SystemConfig.from_info(_info())
    assert (c.bus.interface, c.bus.channel, c.bus.bitrate) == ("socketcan", "can0", 1000000)
    assert c.sdo_timeout == 0.3 and c.max_stale_cycles == 100 and c.sync_period_us == 0
    d = c.drives[0]
    assert (d.joint, d.node_id, d.mode) == ("j1", 2, _cia402.CSP)
    assert d.eds.endswith("cia402_drive.eds")


def test_one_parameter_switches_the_bus() -> None:
    c = SystemConfig.from_info(_info('<param name="interface">udp_multicast</param>'
                                     '<param name="sdo_timeout">0.05</param>'))
    assert str(c.bus) == "udp_multicast:239.74.163.2" and c.sdo_timeout == 0.05


def test_the_mode_follows_the_command_interface_and_scales_invert() -> None:
    c = SystemConfig.from_info(_info(joint1='<param name="node_id">0x7F</param>'
                                     '<param name="scale_vel_to_dev">4096</param>',
                                     command="velocity"))
    d = c.drives[0]
    assert d.node_id == 127 and d.mode == _cia402.CSV
    assert d.scale_vel_from_dev == 1 / 4096


@pytest.mark.parametrize(("hardware", "joint1", "says"), [
    ('<param name="interface">pcan</param>', None, "interface 'pcan' is not one of"),
    ('<param name="sdo_timeout">soon</param>', None, '<param name="sdo_timeout"> \'soon\''),
    ('<param name="sdo_timeout">0</param>', None, "sdo_timeout\"> must be more than 0"),
    ('<param name="max_stale_cycles">-1</param>', None, "max_stale_cycles\"> must be"),
    ("", "", '<joint name="j1">: no <param name="node_id">'),
    ("", '<param name="node_id">128</param>', "node_id 128 is out of 1 to 127"),
    ("", '<param name="node_id">2</param><param name="scale_pos_to_dev">0</param>',
     "scale_pos_to_dev must be finite and not 0"),
])
def test_a_wrong_parameter_is_one_line_naming_it(hardware: str, joint1: str | None,
                                                  says: str) -> None:
    info = _info(hardware) if joint1 is None else _info(hardware, joint1)
    with pytest.raises(ValueError, match=None) as exc:
        SystemConfig.from_info(info)
    assert says in str(exc.value) and "\n" not in str(exc.value)
