"""A Cia402System's write and inactive read on python-can's virtual bus (the bring-up
replaced by two drives' PDO layouts): the RPDOs go only with the SYNC, just before it,
with the newest targets; the bus-load check at configure and at the first cycle."""

from __future__ import annotations

import logging

import pytest

can = pytest.importorskip("can")
canopen = pytest.importorskip("canopen")

from rtcf import CallbackReturn, ReturnType  # noqa: E402
from rtcf._core._robot_description import parse  # noqa: E402
from rtcf_canopen import Cia402System, _system  # noqa: E402
from rtcf_canopen._exchange import (  # noqa: E402
    CONTROLWORD,
    MODE,
    POSITION,
    STATUSWORD,
    TARGET_POSITION,
    TORQUE,
    VELOCITY,
    DriveLayout,
    PdoLayout,
)

from ._urdf import two_drives  # noqa: E402


def _layout(node: int) -> DriveLayout:
    """RPDO 1 (7 bytes), TPDO 1 (7) and TPDO 2 (6): bring_up's for a position joint
    with position and velocity states."""
    return DriveLayout(node, tpdos=[
        PdoLayout(0x180 + node, [(STATUSWORD, "H", 0), (1, "b", 2), (POSITION, "i", 3)], 7),
        PdoLayout(0x280 + node, [(VELOCITY, "i", 0), (TORQUE, "h", 4)], 6),
    ], rpdos=[PdoLayout(0x200 + node, [(CONTROLWORD, "H", 0), (MODE, "b", 2),
                                       (TARGET_POSITION, "i", 3)], 7)])


class _Log(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.lines: list[tuple[int, str]] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append((record.levelno, record.getMessage()))


@pytest.fixture
def make(monkeypatch):
    """``make(params, rw_rate)``: a configured Cia402System on a virtual bus, the drives'
    side of that bus, the result of on_configure and the log lines."""
    made = []

    def build(params: str = "", rw_rate: int = 0):
        channel = f"cadence-{id(object())}"
        master = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
        drive = can.Bus(interface="virtual", channel=channel)
        made.extend((master, drive))
        monkeypatch.setattr(_system, "open_drives", lambda config: (
            canopen.Network(master), [_layout(2), _layout(3)]))
        info = parse(two_drives(hardware=params,
                                attrs=f' rw_rate="{rw_rate}"' if rw_rate else ""))[0]
        logger = logging.getLogger(f"test_sync_cadence.{channel}")
        logger.propagate = False
        logger.setLevel(logging.DEBUG)
        log = _Log()
        logger.addHandler(log)
        hw = Cia402System()
        hw.init(info, logger)
        hw.export_interfaces()
        hw.bind_values(None, None)
        result = hw.on_configure(None)
        while drive.recv(0) is not None:  # the configure's own exchange
            pass
        return hw, drive, result, log.lines

    yield build
    for bus in made:
        bus.shutdown()


def _load_lines(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """The bus-load check's lines (not the drives' silence: nothing answers here)."""
    return [(level, text) for level, text in lines if "bits per SYNC period" in text]


def _sent(drive) -> list[can.Message]:
    out = []
    while (msg := drive.recv(0)) is not None:
        out.append(msg)
    return out


def test_with_a_sync_every_second_write_the_rpdos_go_only_with_it(make) -> None:
    hw, drive, result, _ = make('<param name="sync_period">2000</param>')
    assert result == CallbackReturn.SUCCESS
    per_write = []
    for k in range(6):
        hw.set_command("j1/position", 0.001 * k)
        assert hw.write(k * 0.001, 0.001) == ReturnType.OK
        per_write.append([m.arbitration_id for m in _sent(drive)])
    # before: both RPDOs in every write (12 frames), the SYNC in every second one
    assert per_write == [[], [0x202, 0x203, 0x80]] * 3


def test_the_rpdo_sent_with_the_sync_has_the_newest_target(make) -> None:
    hw, drive, _, _ = make('<param name="sync_period">3000</param>')
    for k, goal in enumerate((0.1, 0.2, 0.3)):
        hw.set_command("j1/position", goal)
        hw.write(k * 0.001, 0.001)
    frames = _sent(drive)
    rpdo = [m for m in frames if m.arbitration_id == 0x202]
    assert len(rpdo) == 1 and int.from_bytes(rpdo[0].data[3:7], "little", signed=True) == 300
    assert frames[-1].arbitration_id == 0x80  # the SYNC last, after the RPDOs


def test_with_a_sync_every_write_each_write_sends_rpdos_and_sync(make) -> None:
    hw, drive, _, _ = make()
    for k in range(3):
        hw.write(k * 0.001, 0.001)
        assert [m.arbitration_id for m in _sent(drive)] == [0x202, 0x203, 0x80]


def test_while_inactive_read_keeps_the_same_sync_period(make) -> None:
    hw, drive, _, _ = make('<param name="sync_period">2000</param>')
    counts = []
    for k in range(4):
        hw.read(k * 0.001, 0.001)
        counts.append(len(_sent(drive)))
    assert counts == [0, 3, 0, 3]


def test_an_overloaded_bus_refuses_configure_in_one_line(make) -> None:
    # 2 drives: SYNC 55 + 2 x (RPDO 125 + TPDO 125 + TPDO 115) = 785 bits; 500 in 1 ms
    _, _, result, lines = make('<param name="interface">socketcan</param>'
                                '<param name="bitrate">500000</param>'
                                '<param name="sync_period">1000</param>')
    assert result == CallbackReturn.ERROR
    errors = [text for level, text in _load_lines(lines) if level == logging.ERROR]
    assert len(errors) == 1 and "\n" not in errors[0]
    assert ("bus socketcan:can0: 2 drive(s) need 785 bits per SYNC period (SYNC, 6 PDOs, "
            "worst-case bit stuffing) of the 500 that 500000 bit/s gives in 1 ms (157%): "
            "the bus is overloaded; raise sync_period to at least 1570 µs") in errors[0]
    assert "fewer drives on this bus" in errors[0] and "map fewer PDOs" in errors[0]


def test_the_rw_rate_gives_the_sync_period_at_configure(make) -> None:
    _, _, result, lines = make('<param name="interface">socketcan</param>'
                               '<param name="bitrate">500000</param>', rw_rate=1000)
    assert result == CallbackReturn.ERROR and "in 1 ms (157%)" in _load_lines(lines)[0][1]


def test_a_load_over_70_percent_is_one_warning(make) -> None:
    # 785 bits of 1000: 78 %
    _, _, result, lines = make('<param name="interface">socketcan</param>'
                               '<param name="sync_period">1000</param>')
    assert result == CallbackReturn.SUCCESS
    said = _load_lines(lines)
    assert len(said) == 1 and said[0][0] == logging.WARNING and "(78%): over 70%" in said[0][1]


def test_unknown_at_configure_the_first_cycle_checks(make) -> None:
    hw, drive, result, lines = make('<param name="interface">socketcan</param>'
                                    '<param name="bitrate">500000</param>')
    assert result == CallbackReturn.SUCCESS  # the loop's period is not known yet
    assert hw.read(0.0, 0.001) == ReturnType.ERROR
    said = _load_lines(lines)
    assert len(said) == 1 and said[0][0] == logging.ERROR and "overloaded" in said[0][1]
    assert _sent(drive) == []


def test_a_longer_sync_period_makes_it_fit(make) -> None:
    hw, _, result, lines = make('<param name="interface">socketcan</param>'
                                '<param name="bitrate">500000</param>'
                                '<param name="sync_period">3000</param>')
    assert result == CallbackReturn.SUCCESS
    said = _load_lines(lines)
    assert said[0][0] == logging.INFO and "(52%)" in said[0][1]  # 785 of 1500
    assert hw.write(0.0, 0.001) == ReturnType.OK  # 3 x 1 ms: as checked, not again
    assert len(_load_lines(lines)) == 1


def test_without_bus_time_the_estimate_is_said_not_checked(make) -> None:
    _, _, result, lines = make('<param name="interface">virtual</param>'
                               '<param name="sync_period">1000</param>'
                               '<param name="bitrate">500000</param>')
    assert result == CallbackReturn.SUCCESS
    said = _load_lines(lines)
    assert len(said) == 1 and said[0][0] == logging.INFO
    assert "virtual has no bus time" in said[0][1] and "would NOT fit" in said[0][1]
