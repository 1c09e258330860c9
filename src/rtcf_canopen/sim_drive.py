"""A simulated CiA 402 drive on a CAN bus: ``python -m rtcf_canopen.sim_drive``.

A canopen ``LocalNode`` with the project's EDS (SDO server, NMT, PDO mapping written by
the master, EMCY) plus what canopen's LocalNode lacks: the CiA 402 state machine
(:mod:`rtcf_canopen._cia402`) and SYNC handling. On each SYNC it takes the last RPDOs
(controlword, mode, targets), steps its state machine and a first-order response of the
motor toward the target (position in CSP, velocity in CSV, torque in CST, with the time
constant ``--tau``), and answers with its TPDOs. Faults and silence on command:
``--fault-after S`` (seconds in OPERATION ENABLED: an EMCY, then FAULT),
``--silent-after S`` (stops answering SYNC after S seconds in OPERATION
ENABLED). It runs canopen's Notifier thread: it is a drive, not the loop.

Example, inside a network namespace (docs/canopen.md)::

    python -m rtcf_canopen.sim_drive --node-id 2 --interface udp_multicast --channel 239.74.163.2
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import struct
import sys
import threading
import time

import can
import canopen

from . import _cia402
from ._config import default_eds


class SimDrive:
    """One simulated drive (a LocalNode on ``network``)."""

    def __init__(self, network: canopen.Network, node_id: int, eds: str, *, tau: float = 0.01,
                 start_position: int = 0, fault_after: float = 0.0, fault_code: int = 0x2310,
                 silent_after: float = 0.0) -> None:
        self.network = network
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self.node_id = node_id
        self.tau = tau
        self.state = _cia402.SWITCH_ON_DISABLED
        self.position = float(start_position)
        self.velocity = 0.0
        self.torque = 0.0
        self.last_cw = 0
        self.fault_after, self.fault_code = fault_after, fault_code
        self.silent_after = silent_after
        self.enabled_since: float | None = None
        self.silent = False
        self.last_sync: float | None = None
        self.pdos_ready = False
        self.syncs = 0
        self.lock = threading.Lock()
        network.subscribe(0x80, self.on_sync)
        network.subscribe(0, self.on_nmt)
        self.node.add_read_callback(self.on_read)

    # -------------------------------------------------------------------- NMT, SDO

    def on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self.node.nmt.state == "OPERATIONAL":
            # the mapping the master wrote (SDO into the data store) is the one used now
            self.node.tpdo.read(from_od=False)
            self.node.rpdo.read(from_od=False)
            self._layouts()
            self.pdos_ready = True
        else:
            self.pdos_ready = False

    def on_read(self, index: int, subindex: int, od: object) -> int | None:
        if index == 0x6041:
            return self.statusword()
        if index == 0x6064:
            return int(self.position)
        if index == 0x603F:
            return self.fault_code if self.state == _cia402.FAULT else 0
        return None

    def statusword(self) -> int:
        return _cia402.STATUSWORD_OF[self.state] | 0x0200  # remote

    # ---------------------------------------------------------------------- SYNC

    def _layouts(self) -> None:
        """The mapped PDOs as structs: (PdoMap, Struct, indices) per RPDO, (COB-ID,
        Struct, indices) per TPDO."""
        rmaps, tmaps = self.node.rpdo.map, self.node.tpdo.map
        assert rmaps is not None and tmaps is not None
        self.rpdos = [(pdo, *_struct_of(pdo)) for pdo in rmaps.values() if pdo.enabled]
        self.tpdos = [(pdo.cob_id, *_struct_of(pdo)) for pdo in tmaps.values() if pdo.enabled]
        self.received: dict[int, int] = {}

    def _take_rpdos(self) -> None:
        for pdo, st, indices in self.rpdos:
            if len(pdo.data) >= st.size:
                self.received.update(zip(indices, st.unpack_from(pdo.data), strict=False))

    def _rpdo(self, index: int, default: int) -> int:
        return self.received.get(index, default)

    def on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if not self.pdos_ready or self.silent:
            return
        with self.lock:
            now = time.monotonic()
            dt = 0.001 if self.last_sync is None else min(0.05, now - self.last_sync)
            self.last_sync = now
            self.syncs += 1
            self.step(now, dt)
            self.transmit()

    def step(self, now: float, dt: float) -> None:
        self._take_rpdos()
        cw = self._rpdo(0x6040, 0)
        mode = self._rpdo(0x6060, _cia402.CSP)
        if self.state == _cia402.FAULT:
            if cw & _cia402.CW_FAULT_RESET and not self.last_cw & _cia402.CW_FAULT_RESET:
                self.state = _cia402.SWITCH_ON_DISABLED
                self.fault_after = 0.0  # a reset clears the simulated cause
                self.node.emcy.reset()
        else:
            self.state = _cia402.drive_transition(self.state, cw)
        self.last_cw = cw
        if self.state == _cia402.OPERATION_ENABLED:
            if self.enabled_since is None:
                self.enabled_since = now
            alive = now - self.enabled_since
            if self.fault_after and alive >= self.fault_after:
                self.state = _cia402.FAULT
                self.node.emcy.send(self.fault_code, 0x01)
                self.velocity = 0.0
                return
            if self.silent_after and alive >= self.silent_after:
                self.silent = True
                return
            a = 1.0 - math.exp(-dt / self.tau) if self.tau > 0 else 1.0
            if mode == _cia402.CSP:
                target = self._rpdo(0x607A, int(self.position))
                new = self.position + (target - self.position) * a
                self.velocity = (new - self.position) / dt
                self.position = new
            elif mode == _cia402.CSV:
                self.velocity += (self._rpdo(0x60FF, 0) - self.velocity) * a
                self.position += self.velocity * dt
            elif mode == _cia402.CST:
                self.torque = float(self._rpdo(0x6071, 0))
                self.velocity += self.torque * dt  # a unit inertia
                self.position += self.velocity * dt
        elif self.state == _cia402.QUICK_STOP_ACTIVE:
            self.velocity = 0.0  # braked on the quick-stop ramp (at once, here)
        else:
            self.velocity = 0.0
            self.enabled_since = None

    def transmit(self) -> None:
        values = {0x6041: self.statusword(), 0x6061: self._rpdo(0x6060, 0),
                  0x6064: _clamp32(self.position), 0x606C: _clamp32(self.velocity),
                  0x6077: max(-32768, min(32767, int(self.torque))),
                  0x603F: self.fault_code if self.state == _cia402.FAULT else 0}
        bus = self.network.bus
        assert bus is not None
        for cob_id, st, indices in self.tpdos:
            data = st.pack(*[values.get(i, 0) for i in indices])
            bus.send(can.Message(arbitration_id=cob_id, is_extended_id=False, data=data))


def _struct_of(pdo: object) -> tuple[struct.Struct, tuple[int, ...]]:
    codes = {1: "B", 2: "b", 3: "h", 4: "i", 5: "B", 6: "H", 7: "I"}
    fmt, indices = "<", []
    for var in pdo.map:  # type: ignore[attr-defined]
        fmt += codes[var.od.data_type]
        indices.append(var.index)
    return struct.Struct(fmt), tuple(indices)


def _clamp32(x: float) -> int:
    return max(-(2**31), min(2**31 - 1, round(x)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rtcf_canopen.sim_drive", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--node-id", type=int, action="append", required=True,
                    help="the drive's node id (repeat for several drives in one process)")
    ap.add_argument("--interface", default="udp_multicast")
    ap.add_argument("--channel", default="239.74.163.2")
    ap.add_argument("--eds", default=default_eds())
    ap.add_argument("--tau", type=float, default=0.01, help="time constant [s]")
    ap.add_argument("--start-position", type=int, default=0, help="counts")
    ap.add_argument("--fault-after", type=float, default=0.0,
                    help="seconds in OPERATION ENABLED before a fault (0: never)")
    ap.add_argument("--fault-code", type=lambda t: int(t, 0), default=0x2310,
                    help="the EMCY error code of the fault (default 0x2310, over-current)")
    ap.add_argument("--silent-after", type=float, default=0.0,
                    help="seconds in OPERATION ENABLED before it stops answering (0: never)")
    ap.add_argument("--priority", type=int, default=0,
                    help="SCHED_FIFO priority of the drive's process (0: none): a real "
                         "drive answers within microseconds")
    ap.add_argument("--duration", type=float, default=0.0, help="exit after (0: on SIGTERM)")
    args = ap.parse_args(argv)
    if args.priority:
        try:  # before the Notifier's thread starts: it inherits the policy
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.priority))
        except OSError as exc:
            print(f"sim_drive: SCHED_FIFO not applied ({exc})", file=sys.stderr)
    kwargs = {"fd": False} if args.interface == "udp_multicast" else {}
    network = canopen.Network()
    network.connect(interface=args.interface, channel=args.channel, **kwargs)
    drives = [SimDrive(network, nid, args.eds, tau=args.tau, start_position=args.start_position,
                       fault_after=args.fault_after, fault_code=args.fault_code,
                       silent_after=args.silent_after) for nid in args.node_id]
    for drive in drives:
        drive.node.nmt.state = "PRE-OPERATIONAL"
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    print(f"sim_drive: node(s) {', '.join(map(str, args.node_id))} on {args.interface}:"
          f"{args.channel}", flush=True)
    stop.wait(args.duration or None)
    for drive in drives:
        print(f"sim_drive: node {drive.node_id}: {drive.syncs} SYNCs answered, state "
              f"{_cia402.STATE_NAMES[drive.state]}", flush=True)
    network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
