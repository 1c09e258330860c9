"""The cyclic exchange without a network: python-can's virtual bus in this process, a
drive's TPDOs written by hand; decoding, stale counting, EMCY, and what stays allocated."""

from __future__ import annotations

import struct
import tracemalloc

import pytest

can = pytest.importorskip("can")
pytest.importorskip("canopen")

from rtcf_canopen._exchange import (  # noqa: E402
    CONTROLWORD,
    MODE,
    POSITION,
    STATUSWORD,
    TARGET_POSITION,
    VELOCITY,
    DriveLayout,
    Exchange,
    PdoLayout,
)


def _layout(node: int) -> DriveLayout:
    return DriveLayout(node, tpdos=[
        PdoLayout(0x180 + node, [(STATUSWORD, "H", 0), (1, "b", 2), (POSITION, "i", 3)], 7),
        PdoLayout(0x280 + node, [(VELOCITY, "i", 0), (4, "h", 4)], 6),
    ], rpdos=[PdoLayout(0x200 + node, [(CONTROLWORD, "H", 0), (MODE, "b", 2),
                                       (TARGET_POSITION, "i", 3)], 7)])


@pytest.fixture
def buses():
    channel = f"rtcf-test-{id(object())}"
    master = can.Bus(interface="virtual", channel=channel)
    drive = can.Bus(interface="virtual", channel=channel)
    yield master, drive
    master.shutdown()
    drive.shutdown()


def _answer(drive, node: int, sw: int, pos: int, vel: int, tpdo2: bool = True) -> None:
    drive.send(can.Message(arbitration_id=0x180 + node, is_extended_id=False,
                           data=struct.pack("<Hbi", sw, 8, pos)))
    if tpdo2:
        drive.send(can.Message(arbitration_id=0x280 + node, is_extended_id=False,
                               data=struct.pack("<ih", vel, 0)))


def test_tpdos_are_decoded_into_the_arrays(buses) -> None:
    master, drive = buses
    ex = Exchange(master, [_layout(2), _layout(3)])
    ex.send_sync()
    _answer(drive, 2, 0x0237, -123456, 77)
    _answer(drive, 3, 0x0227, 2**31 - 1, -5)
    ex.drain()
    ex.finish_cycle()
    assert ex.position.tolist() == [-123456, 2**31 - 1] and ex.velocity.tolist() == [77, -5]
    assert ex.tpdo[POSITION] is ex.position and ex.tpdo[VELOCITY] is ex.velocity
    assert ex.statusword.tolist() == [0x0237, 0x0227]
    assert ex.age.tolist() == [0, 0] and ex.stale.tolist() == [0, 0] and ex.all_fresh


def test_rpdos_and_sync_are_sent_from_the_rows(buses) -> None:
    master, drive = buses
    ex = Exchange(master, [_layout(2)])
    ex.rpdo[CONTROLWORD][0], ex.rpdo[MODE][0], ex.rpdo[TARGET_POSITION][0] = 0x0F, 8, -42
    ex.send_rpdos()
    ex.send_sync()
    rpdo, sync = drive.recv(0.1), drive.recv(0.1)
    assert rpdo.arbitration_id == 0x202 and struct.unpack("<Hbi", rpdo.data) == (0x0F, 8, -42)
    assert sync.arbitration_id == 0x80 and len(sync.data) == 0


def test_a_missing_tpdo_is_a_stale_cycle_and_the_value_is_kept(buses) -> None:
    master, drive = buses
    ex = Exchange(master, [_layout(2), _layout(3)])
    ex.send_sync()
    _answer(drive, 2, 0x0237, 100, 1)
    _answer(drive, 3, 0x0237, 200, 2)
    ex.drain()
    ex.finish_cycle()
    for k in range(3):  # node 3 silent; node 2 misses its second TPDO once
        ex.send_sync()
        _answer(drive, 2, 0x0237, 101 + k, 1, tpdo2=k != 1)
        ex.drain()
        ex.finish_cycle()
    assert ex.age.tolist() == [0, 3] and ex.stale.tolist() == [1, 3]
    assert ex.longest.tolist() == [1, 3] and not ex.all_fresh
    assert ex.position.tolist() == [103, 200]  # node 3's kept, marked old by its age
    # no SYNC sent: nothing was expected, nothing is stale
    ex.drain()
    ex.finish_cycle()
    assert ex.stale.tolist() == [1, 3]


def test_an_emcy_gives_the_error_code_and_a_short_frame_is_counted(buses) -> None:
    master, drive = buses
    ex = Exchange(master, [_layout(2)])
    drive.send(can.Message(arbitration_id=0x82, is_extended_id=False,
                           data=struct.pack("<HB5x", 0x7305, 0x01)))
    drive.send(can.Message(arbitration_id=0x182, is_extended_id=False, data=b"\x08\x00"))
    ex.drain()
    assert ex.emcy_code.tolist() == [0x7305] and ex.emcy_register.tolist() == [0x01]
    assert ex.emcy_seen and ex.bad_frames == 1
    assert ex.got == bytearray(1)  # the short TPDO counts for nothing


def test_a_longer_frame_counts_with_its_first_bytes(buses) -> None:
    master, drive = buses
    ex = Exchange(master, [_layout(2)])
    drive.send(can.Message(arbitration_id=0x182, is_extended_id=False,
                           data=struct.pack("<Hbi", 0x0237, 8, 5) + b"\xff"))
    ex.drain()
    assert ex.position.tolist() == [5] and ex.got == bytearray([1]) and ex.bad_frames == 0


def test_drives_mapped_unlike_each_other_are_refused_naming_both() -> None:
    other = _layout(3)
    other.tpdos[0] = PdoLayout(0x183, [(STATUSWORD, "H", 0), (POSITION, "i", 2)], 6)
    with pytest.raises(ValueError, match=r"node 3 maps object .* unlike node 2"):
        Exchange(None, [_layout(2), other])  # type: ignore[arg-type]


def test_a_cycle_keeps_nothing_allocated(buses) -> None:
    """What rtcf's side keeps per cycle: nothing (python-can's Message per frame is
    freed when the frame is decoded)."""
    master, drive = buses
    ex = Exchange(master, [_layout(n) for n in range(2, 8)])

    def cycle(k: int) -> None:
        ex.target_position[:] = k
        ex.send_rpdos()
        ex.send_sync()
        for n in range(2, 8):
            _answer(drive, n, 0x0237, k, 1)
        while drive.recv(0) is not None:  # the drive side's inbox
            pass
        ex.drain()
        ex.finish_cycle()

    tracemalloc.start()
    for k in range(300):  # values kept from here on replace ones traced too
        cycle(k)
    before = tracemalloc.take_snapshot()
    for k in range(300, 800):
        cycle(k)
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = [s for s in after.compare_to(before, "lineno")
             if "rtcf_canopen" in str(s.traceback) and s.size_diff > 0]
    # 500 cycles of 6 drives (7 frames out, 24 in per cycle): at most a tuple or two
    # parked in CPython's free lists, which tracemalloc counts as alive
    assert sum(s.size_diff for s in grown) <= 256, grown


def test_the_kernel_filters_pass_the_drives_tpdos_and_emcys_only(buses) -> None:
    master, _ = buses
    ex = Exchange(master, [_layout(2), _layout(3)])
    ids = [f["can_id"] for f in ex.filters()]
    assert ids == [0x82, 0x83, 0x182, 0x183, 0x282, 0x283]  # no SYNC, RPDO, SDO, NMT
    assert all(f["can_mask"] == 0x7FF and f["extended"] is False for f in ex.filters())
