"""What a Cia402System is told in its URDF: the ``<hardware>``'s bus and timing
``<param>``s and, per ``<joint>``, its drive (node id, EDS/DCF, unit scales).

Read once in ``on_init``; every error is one line naming the tag and the parameter
(docs/canopen.md lists them all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources

import rtcf

from . import _cia402
from ._bus import INTERFACES, BusSettings

_DEFAULT_CHANNEL = {"socketcan": "can0", "udp_multicast": "239.74.163.2", "virtual": "rtcf"}
_SCALES = ("scale_pos_to_dev", "scale_pos_from_dev", "offset_pos_to_dev",
           "offset_pos_from_dev", "scale_vel_to_dev", "scale_vel_from_dev",
           "scale_eff_to_dev", "scale_eff_from_dev")


def default_eds() -> str:
    """The project's own CiA 402 EDS (rtcf_canopen/data/cia402_drive.eds)."""
    return str(resources.files("rtcf_canopen") / "data" / "cia402_drive.eds")


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
    for name in _SCALES:
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


@dataclass
class SystemConfig:
    """The ``<hardware>``'s ``<param>``s and the drives of its joints."""

    bus: BusSettings
    sync_period_us: float  # SYNC every n-th write, n = sync_period / the loop's period
    activate_timeout: float  # s, to OPERATION ENABLED
    max_stale_cycles: int  # cycles without an answer before read is an ERROR (0: never)
    sdo_timeout: float  # s, per SDO request of the bring-up
    drives: list[DriveConfig]

    @classmethod
    def from_info(cls, info: rtcf.HardwareInfo) -> SystemConfig:
        """From the description (ValueError: one line naming the parameter)."""
        p = info.hardware_parameters
        interface = p.get("interface", "socketcan")
        if interface not in INTERFACES:
            raise ValueError(f"interface {interface!r} is not one of {', '.join(INTERFACES)}")

        def number(name: str, default: str, kind: type = float) -> float:
            try:
                value = kind(p.get(name, default))
            except ValueError:
                raise ValueError(f"<param name=\"{name}\"> {p[name]!r} is not a "
                                 "number") from None
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"<param name=\"{name}\"> must be finite and not negative")
            return value

        config = cls(
            BusSettings(interface, p.get("channel", _DEFAULT_CHANNEL[interface]),
                        int(number("bitrate", "1000000", int))),
            number("sync_period", "0"), number("activate_timeout", "1.0"),
            int(number("max_stale_cycles", "100", int)), number("sdo_timeout", "0.3"),
            [config_of(j.name, dict(j.parameters),
                       tuple(i.name for i in j.command_interfaces),
                       tuple(i.name for i in j.state_interfaces)) for j in info.joints])
        ids = [d.node_id for d in config.drives]
        if len(set(ids)) != len(ids):
            raise ValueError(f"two joints have the same node_id ({', '.join(map(str, ids))})")
        if config.sdo_timeout <= 0:
            raise ValueError("<param name=\"sdo_timeout\"> must be more than 0 s")
        return config
