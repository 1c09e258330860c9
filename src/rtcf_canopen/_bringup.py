"""The bring-up of a Cia402System's drives over SDO, outside the loop, and the bus's close.

The bring-up is ros2_canopen's (``canopen_402_driver``, with the PDO mapping its
``bus.yml`` gives a CiA 402 drive), made with canopen's own objects on a network that no
thread receives for (:mod:`._bus`): NMT pre-operational, the PDO mapping written with
canopen's ``PdoMap`` (RPDO 1 controlword, mode of operation and target position; RPDO 2
target velocity and torque; TPDO 1 statusword, mode display and actual position; TPDO 2
actual velocity and torque: the second ones only where the joint has those
interfaces), every PDO synchronous (transmission type 1: on each SYNC), the mode of
operation by SDO, NMT operational.
"""

from __future__ import annotations

import contextlib

import canopen
from canopen.objectdictionary import (
    INTEGER8,
    INTEGER16,
    INTEGER32,
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
)
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from . import _cia402
from ._bus import PolledRemoteNode, quiet_canopen
from ._config import DriveConfig, SystemConfig
from ._exchange import RPDO_FIELDS, TPDO_FIELDS, DriveLayout, PdoLayout

_CODES = {UNSIGNED8: "B", INTEGER8: "b", UNSIGNED16: "H", INTEGER16: "h",
          UNSIGNED32: "I", INTEGER32: "i"}


class DriveError(Exception):
    """A drive could not be brought up: one line naming it, the bus and what to do."""


def open_drives(config: SystemConfig) -> tuple[canopen.Network, list[DriveLayout]]:
    """Open the bus and bring every drive up over SDO, outside the loop; the network
    (no Notifier thread) and each drive's PDO layouts. DriveError: one line naming the
    bus or the drive and what to do."""
    settings = config.bus
    try:
        bus = settings.open()
    except Exception as exc:  # python-can's errors, OSError: the bus is not there
        raise DriveError(
            f"cannot open the CAN bus {settings} ({exc}): check the interface and channel "
            "parameters (on a robot: interface socketcan, channel can0, the link up with "
            f"'ip link set can0 up type can bitrate {settings.bitrate}')") from None
    network = canopen.Network(bus)  # no connect(): no Notifier thread
    try:
        with quiet_canopen():
            layouts = [bring_up(network, drive, str(settings), config.sdo_timeout)
                       for drive in config.drives]
    except DriveError:
        close(network)
        raise
    return network, layouts


def close(network: canopen.Network, pre_operational: bool = False) -> None:
    """The drives to NMT pre-operational (if asked; not waited for) and the bus shut."""
    if pre_operational:
        with contextlib.suppress(Exception), quiet_canopen():
            for node in network.values():
                node.nmt.state = "PRE-OPERATIONAL"
    bus, network.bus = network.bus, None
    if bus is not None:
        with contextlib.suppress(Exception):
            bus.shutdown()


def bring_up(network: canopen.Network, cfg: DriveConfig, bus: str,
             sdo_timeout: float = 0.3) -> DriveLayout:
    """Bring one drive up over SDO; its PDOs' layouts as mapped (DriveError if not)."""
    who = cfg.name(bus)
    try:
        node = PolledRemoteNode(cfg.node_id, cfg.eds)
    except (OSError, ValueError, KeyError) as exc:
        raise DriveError(f"{who}: cannot read its EDS/DCF {cfg.eds!r} ({exc}): give the "
                         "drive's file as <param name=\"eds\">") from None
    network.add_node(node)
    node.sdo.RESPONSE_TIMEOUT = sdo_timeout
    try:
        node.sdo.upload(0x1000, 0)  # device type: is it there?
    except SdoCommunicationError:
        raise DriveError(
            f"{who} did not answer (no SDO response to reading its device type 0x1000 "
            f"within {node.sdo.RESPONSE_TIMEOUT:.1f} s): check that it is powered and "
            "connected, its node id, and the bus's interface, channel and bitrate") from None
    except SdoAbortedError as exc:
        raise DriveError(f"{who}: refused reading its device type 0x1000 ({exc})") from None
    try:
        node.nmt.state = "PRE-OPERATIONAL"
        od = node.object_dictionary
        if 0x6502 in od:
            supported = node.sdo[0x6502].raw
            bit = _cia402.SUPPORTED_BIT[cfg.mode]
            if isinstance(supported, int) and not supported & bit:
                raise DriveError(
                    f"{who} does not support {_cia402.MODE_NAMES[cfg.mode]} (0x6502 = "
                    f"0x{supported:08X}): give the joint a command interface of a mode it has")
        rp1, rp2, tp1, tp2 = node.rpdo[1], node.rpdo[2], node.tpdo[1], node.tpdo[2]
        _map(rp1, 0x200 + cfg.node_id, (0x6040, 0x6060, 0x607A))
        _map(rp2, 0x300 + cfg.node_id, (0x60FF, 0x6071) if cfg.needs_rpdo2 else ())
        _map(tp1, 0x180 + cfg.node_id, (0x6041, 0x6061, 0x6064))
        _map(tp2, 0x280 + cfg.node_id, (0x606C, 0x6077) if cfg.needs_tpdo2 else ())
        for pdo in (rp1, rp2, tp1, tp2):
            pdo.save()
        node.sdo[0x6060].raw = cfg.mode
        node.nmt.state = "OPERATIONAL"
    except SdoCommunicationError as exc:
        raise DriveError(f"{who} stopped answering during its bring-up ({exc}): check its "
                         "power and the bus") from None
    except SdoAbortedError as exc:
        raise DriveError(f"{who} refused its PDO mapping or mode of operation ({exc}): "
                         "check that its EDS/DCF is the drive's") from None
    layout = DriveLayout(cfg.node_id)
    for pdo, table, into in ((tp1, TPDO_FIELDS, layout.tpdos), (tp2, TPDO_FIELDS, layout.tpdos),
                             (rp1, RPDO_FIELDS, layout.rpdos), (rp2, RPDO_FIELDS, layout.rpdos)):
        if not pdo.enabled:
            continue
        fields = [(table[v.index], _CODES[v.od.data_type], v.offset // 8) for v in pdo.map]
        into.append(PdoLayout(pdo.cob_id, fields, len(pdo.data)))
    return layout


def _map(pdo: canopen.pdo.PdoMap, cob_id: int, indices: tuple[int, ...]) -> None:
    """Map ``indices`` into ``pdo``, synchronous (or disable it if there are none)."""
    pdo.clear()
    for index in indices:
        pdo.add_variable(index)
    pdo.cob_id = cob_id
    pdo.trans_type = 1
    pdo.enabled = bool(indices)
