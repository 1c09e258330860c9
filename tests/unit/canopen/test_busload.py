"""The worst-case bits of a CANopen SYNC period (rtcf_canopen._busload) and the numbers
docs/canopen.md gives for 1, 2 and 6 drives at 1 Mbit/s."""

from __future__ import annotations

import pytest

pytest.importorskip("canopen")

from rtcf_canopen._busload import BusLoad, frame_bits
from rtcf_canopen._exchange import DriveLayout, PdoLayout


def test_frame_bits_are_the_classic_worst_case() -> None:
    # 47 + 8 s, plus floor((34 + 8 s - 1) / 4) stuff bits
    assert [frame_bits(s) for s in (0, 1, 6, 7, 8)] == [55, 65, 115, 125, 135]


def _drive(node: int, tpdo2: bool = True) -> DriveLayout:
    tpdos = [PdoLayout(0x180 + node, [], 7)] + ([PdoLayout(0x280 + node, [], 6)] if tpdo2
                                                 else [])
    return DriveLayout(node, tpdos=tpdos, rpdos=[PdoLayout(0x200 + node, [], 7)])


@pytest.mark.parametrize(("drives", "bits", "at_1ms", "at_2ms"), [
    (1, 420, "info", "info"), (2, 785, "warning", "info"), (6, 2245, "error", "error"),
])
def test_the_documented_numbers(drives: int, bits: int, at_1ms: str, at_2ms: str) -> None:
    load = BusLoad.of([_drive(n) for n in range(2, 2 + drives)])
    assert load.bits == bits and load.frames == 1 + 3 * drives
    assert load.check("can0", "socketcan", 1_000_000, 0.001)[0] == at_1ms
    assert load.check("can0", "socketcan", 1_000_000, 0.002)[0] == at_2ms


def test_six_drives_fit_with_one_tpdo_at_2ms_or_with_two_at_3ms() -> None:
    one = BusLoad.of([_drive(n, tpdo2=False) for n in range(2, 8)])
    assert one.bits == 1555 and one.check("can0", "socketcan", 1_000_000, 0.002)[0] == "warning"
    two = BusLoad.of([_drive(n) for n in range(2, 8)])
    assert two.check("can0", "socketcan", 1_000_000, 0.003)[0] == "warning"  # 75 %
    assert two.check("can0", "socketcan", 1_000_000, 0.004)[0] == "info"  # 56 %
