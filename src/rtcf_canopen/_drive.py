"""One drive of a Cia402System: its joint's parameters, and its bring-up over SDO.

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

import math
from dataclasses import dataclass
from importlib import resources

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
from ._bus import PolledRemoteNode
from ._exchange import RPDO_FIELDS, TPDO_FIELDS, DriveLayout, PdoLayout

_CODES = {UNSIGNED8: "B", INTEGER8: "b", UNSIGNED16: "H", INTEGER16: "h",
          UNSIGNED32: "I", INTEGER32: "i"}


def default_eds() -> str:
    """The project's own CiA 402 EDS (rtcf_canopen/data/cia402_drive.eds)."""
    return str(resources.files("rtcf_canopen") / "data" / "cia402_drive.eds")


class DriveError(Exception):
    """A drive could not be brought up: one line naming it, the bus and what to do."""


@dataclass
class DriveConfig:
    """A ``<joint>``'s drive: its ``<param>``s and its interfaces."""

    joint: str
    node_id: int
    eds: str
    mode: int  # CSP, CSV or CST, from the joint's first command interface
    commands: tuple[str, ...]  # position, velocity, effort: those the joint has
    states: tuple[str, ...]
    # device units = value * to_dev + offset_to_dev; value = device * from_dev + offset_from_dev
    scale_pos_to_dev: float = 1000.0
    scale_pos_from_dev: float = 0.001
    offset_pos_to_dev: float = 0.0
    offset_pos_from_dev: float = 0.0
    scale_vel_to_dev: float = 1000.0
    scale_vel_from_dev: float = 0.001
    scale_eff_to_dev: float = 1.0
    scale_eff_from_dev: float = 1.0

    def name(self, bus: str) -> str:
        return f"CANopen drive node {self.node_id} (joint '{self.joint}') on bus {bus}"

    @property
    def needs_rpdo2(self) -> bool:
        return "velocity" in self.commands or "effort" in self.commands

    @property
    def needs_tpdo2(self) -> bool:
        return "velocity" in self.states or "effort" in self.states


def config_of(joint: str, params: dict[str, str], commands: tuple[str, ...],
              states: tuple[str, ...]) -> DriveConfig:
    """A joint's DriveConfig from its ``<param>``s (ValueError: one line naming it)."""
    where = f"<joint name=\"{joint}\">"
    if "node_id" not in params:
        raise ValueError(f"{where}: no <param name=\"node_id\"> (the drive's CANopen node "
                         "id, 1 to 127)")
    try:
        node_id = int(params["node_id"], 0)
    except ValueError:
        raise ValueError(f"{where}: node_id {params['node_id']!r} is not a number") from None
    if not 1 <= node_id <= 127:
        raise ValueError(f"{where}: node_id {node_id} is out of 1 to 127")
    known = [c for c in commands if c in _cia402.MODE_OF_INTERFACE]
    if not known:
        raise ValueError(f"{where}: needs a command interface position, velocity or effort "
                         f"(it has {', '.join(commands) or 'none'}): the mode of operation "
                         "(cyclic synchronous position, velocity or torque) follows it")
    cfg = DriveConfig(joint, node_id, params.get("eds") or params.get("dcf") or default_eds(),
                      _cia402.MODE_OF_INTERFACE[known[0]], tuple(known),
                      tuple(s for s in states if s in ("position", "velocity", "effort")))
    for name in ("scale_pos_to_dev", "scale_pos_from_dev", "offset_pos_to_dev",
                 "offset_pos_from_dev", "scale_vel_to_dev", "scale_vel_from_dev",
                 "scale_eff_to_dev", "scale_eff_from_dev"):
        if name in params:
            try:
                value = float(params[name])
            except ValueError:
                raise ValueError(f"{where}: {name} {params[name]!r} is not a number") from None
            if not math.isfinite(value) or (name.startswith("scale") and value == 0):
                raise ValueError(f"{where}: {name} must be finite and not 0")
            setattr(cfg, name, value)
    # given one direction only: the other is its inverse (counts per radian, say)
    for kind in ("pos", "vel", "eff"):
        to, frm = f"scale_{kind}_to_dev", f"scale_{kind}_from_dev"
        if to in params and frm not in params:
            setattr(cfg, frm, 1.0 / getattr(cfg, to))
        elif frm in params and to not in params:
            setattr(cfg, to, 1.0 / getattr(cfg, frm))
    return cfg


def bring_up(network: canopen.Network, cfg: DriveConfig, bus: str) -> DriveLayout:
    """Bring one drive up over SDO; its PDOs' layouts as mapped (DriveError if not)."""
    who = cfg.name(bus)
    try:
        node = PolledRemoteNode(cfg.node_id, cfg.eds)
    except (OSError, ValueError, KeyError) as exc:
        raise DriveError(f"{who}: cannot read its EDS/DCF {cfg.eds!r} ({exc}): give the "
                         "drive's file as <param name=\"eds\">") from None
    network.add_node(node)
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
