"""Units and targets of a Cia402System without a bus: the exchange's views on python-can's
virtual bus, the hardware's arrays bound as the resource manager binds them."""

from __future__ import annotations

import logging
import math
import struct

import pytest

can = pytest.importorskip("can")
pytest.importorskip("canopen")

from rtcf._core._robot_description import parse  # noqa: E402
from rtcf_canopen import Cia402System, _cia402  # noqa: E402
from rtcf_canopen._config import SystemConfig  # noqa: E402
from rtcf_canopen._exchange import (  # noqa: E402
    CONTROLWORD,
    MODE,
    POSITION,
    STATUSWORD,
    TARGET_POSITION,
    TARGET_VELOCITY,
    TORQUE,
    VELOCITY,
    DriveLayout,
    Exchange,
    PdoLayout,
)
from rtcf_canopen._units import Units  # noqa: E402

from ._urdf import two_drives  # noqa: E402

URDF = two_drives(j1='<param name="scale_pos_to_dev">4096</param>'
                       '<param name="offset_pos_to_dev">10</param>'
                       '<param name="offset_pos_from_dev">0.5</param>', j2_command="velocity")


def _layout(node: int) -> DriveLayout:
    return DriveLayout(node, tpdos=[
        PdoLayout(0x180 + node, [(STATUSWORD, "H", 0), (1, "b", 2), (POSITION, "i", 3)], 7),
        PdoLayout(0x280 + node, [(VELOCITY, "i", 0), (TORQUE, "h", 4)], 6),
    ], rpdos=[PdoLayout(0x200 + node, [(CONTROLWORD, "H", 0), (MODE, "b", 2),
                                       (TARGET_POSITION, "i", 3)], 7),
              PdoLayout(0x300 + node, [(TARGET_VELOCITY, "i", 0), (6, "h", 4)], 6)])


@pytest.fixture
def setup():
    info = parse(URDF)[0]
    config = SystemConfig.from_info(info)
    hw = Cia402System()
    hw.init(info, logging.getLogger("test_units"))
    hw.export_interfaces()
    hw.bind_values(None, None)
    channel = f"units-{id(object())}"
    master = can.Bus(interface="virtual", channel=channel)
    drive = can.Bus(interface="virtual", channel=channel)
    ex = Exchange(master, [_layout(2), _layout(3)])
    yield hw, Units(hw, config.drives, ex), ex, drive
    master.shutdown()
    drive.shutdown()


def _answer(drive, node: int, sw: int, pos: int, vel: int) -> None:
    drive.send(can.Message(arbitration_id=0x180 + node, is_extended_id=False,
                           data=struct.pack("<Hbi", sw, 8, pos)))
    drive.send(can.Message(arbitration_id=0x280 + node, is_extended_id=False,
                           data=struct.pack("<ih", vel, 0)))


def test_states_in_si_units_with_the_extra_interfaces(setup) -> None:
    hw, units, ex, drive = setup
    ex.send_sync()
    _answer(drive, 2, 0x0237, 4096, 2000)
    _answer(drive, 3, 0x0208, -1000, 0)  # node 3 in FAULT
    ex.drain()
    ex.finish_cycle()
    units.to_states(active=False)
    # scale_pos_to_dev 4096 alone: from the device, 1/4096 (then its own offset 0.5)
    assert hw.get_state("j1/position") == pytest.approx(4096 / 4096 + 0.5)
    assert hw.get_state("j1/velocity") == pytest.approx(2.0)
    assert hw.get_state("j2/position") == pytest.approx(-1.0)
    assert hw.get_state("j1/statusword") == 0x0237 and hw.get_state("j2/statusword") == 0x0208
    assert hw.get_state("j1/cia402_state") == _cia402.OPERATION_ENABLED
    assert hw.get_state("j2/cia402_state") == _cia402.FAULT
    assert units.state_bytes == bytes([_cia402.OPERATION_ENABLED, _cia402.FAULT])
    assert hw.get_state("j2/pdo_age") == 0 and hw.get_state("j2/error_code") == 0
    # not commanding: the position targets follow the drives
    assert ex.target_position.tolist() == [4096, -1000]
    # the next SYNC unanswered by node 3: its age and stale count show, its values stay
    ex.send_sync()
    _answer(drive, 2, 0x0237, 4100, 0)
    ex.drain()
    ex.finish_cycle()
    units.to_states(active=True)
    assert hw.get_state("j2/pdo_age") == 1 and hw.get_state("j2/stale_cycles") == 1
    assert hw.get_state("j2/position") == pytest.approx(-1.0)


def test_commands_to_targets_scaled_rounded_clamped_and_nan_held(setup) -> None:
    hw, units, ex, _ = setup
    hw.set_command("j1/position", 0.25)
    hw.set_command("j2/velocity", -3.3337)
    units.to_targets()
    assert ex.target_position[0] == round(0.25 * 4096 + 10)
    assert ex.rpdo[TARGET_VELOCITY][1] == -3334  # 1000 per unit, rounded
    hw.set_command("j1/position", float("nan"))
    hw.set_command("j2/velocity", 1e12)
    units.to_targets()
    assert ex.target_position[0] == round(0.25 * 4096 + 10)  # NaN: the target held
    assert ex.rpdo[TARGET_VELOCITY][1] == 2**31 - 1  # clamped to the object's range
    # j1 has no velocity command: its drive's target velocity is never written
    assert ex.rpdo[TARGET_VELOCITY][0] == 0


def test_activation_holds_where_the_drives_are(setup) -> None:
    hw, units, ex, drive = setup
    ex.send_sync()
    _answer(drive, 2, 0x0237, 2048, 0)
    _answer(drive, 3, 0x0237, 0, 0)
    ex.drain()
    ex.finish_cycle()
    units.to_states(active=False)
    units.hold()
    assert math.isclose(hw.get_command("j1/position"), hw.get_state("j1/position"))
    assert hw.get_command("j2/velocity") == 0.0
