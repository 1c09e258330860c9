"""The cyclic exchange with the drives: frames drained without blocking, TPDOs decoded
into preallocated arrays, RPDOs and SYNC sent from preallocated messages.

This is all of the bus work a Cia402System does in the loop. No thread receives:
``drain`` takes what the bus holds with python-can's ``recv(timeout=0)`` (one
non-blocking poll per frame, no filters, since a filtered frame would end python-can's
non-blocking ``recv`` early) and dispatches each frame by its COB-ID through one dict
look-up to a precompiled ``struct.Struct.unpack_from`` of that PDO's layout, whose
values go into a float64 array in place. A drive whose TPDOs did not all arrive since
the last SYNC keeps its values and counts a stale cycle (``age``: cycles since it was
last complete, 0 when fresh; ``stale``: all stale cycles); nothing waits for it.

What python-can still allocates per frame (its ``Message``, and on udp_multicast the
msgpack dict) is its own; rtcf adds no objects that outlive a cycle
(tests/unit/canopen/test_exchange.py counts them with tracemalloc).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import can
import numpy as np

# TPDO fields: columns of ``Exchange.raw`` (device units)
STATUSWORD, MODE_DISPLAY, POSITION, VELOCITY, TORQUE, ERROR_CODE = range(6)
TPDO_FIELDS = {0x6041: STATUSWORD, 0x6061: MODE_DISPLAY, 0x6064: POSITION,
               0x606C: VELOCITY, 0x6077: TORQUE, 0x603F: ERROR_CODE}
N_TPDO_FIELDS = 6
# RPDO fields: places of ``Exchange.out`` rows (Python ints, device units)
CONTROLWORD, MODE, TARGET_POSITION, TARGET_VELOCITY, TARGET_TORQUE = range(5)
RPDO_FIELDS = {0x6040: CONTROLWORD, 0x6060: MODE, 0x607A: TARGET_POSITION,
               0x60FF: TARGET_VELOCITY, 0x6071: TARGET_TORQUE}
SYNC_COB_ID = 0x80
EMCY_BASE = 0x80


@dataclass
class PdoLayout:
    """One PDO of one drive: its COB-ID and its fields as (column, struct code, byte
    offset), from the mapping canopen wrote to the drive."""

    cob_id: int
    fields: list[tuple[int, str, int]]
    length: int  # bytes

    def struct(self) -> struct.Struct:
        fmt, at = "<", 0
        for _, code, offset in sorted(self.fields, key=lambda f: f[2]):
            if offset > at:
                fmt += f"{offset - at}x"
            fmt += code
            at = offset + struct.calcsize("<" + code)
        if self.length > at:
            fmt += f"{self.length - at}x"
        return struct.Struct(fmt)

    def columns(self) -> tuple[int, ...]:
        return tuple(c for c, _, _ in sorted(self.fields, key=lambda f: f[2]))


@dataclass
class DriveLayout:
    node_id: int
    tpdos: list[PdoLayout] = field(default_factory=list)
    rpdos: list[PdoLayout] = field(default_factory=list)


class Exchange:
    """The per-cycle exchange of SYNC, RPDOs and TPDOs with a set of drives."""

    def __init__(self, bus: can.BusABC, drives: Sequence[DriveLayout]) -> None:
        self.bus = bus
        self.node_ids = [d.node_id for d in drives]
        n = self.n = len(drives)
        self.raw = np.zeros((n, N_TPDO_FIELDS))  # the last decoded values, device units
        self._flat = self.raw.reshape(-1)
        self.statusword = [0] * n
        self.emcy_code = [0] * n  # the last EMCY's error code (0: none or reset)
        self.emcy_register = [0] * n
        self.age = [0] * n  # cycles since the drive's TPDOs last all arrived
        self.stale = [0] * n  # stale cycles, in all
        self.longest = [0] * n  # the longest run of stale cycles
        self.syncs = 0
        self.frames = 0  # frames drained, in all (ours echoed back and others included)
        self.bad_frames = 0  # a PDO shorter than its mapping
        self.send_errors = 0  # a frame the bus refused (full, down): not retried
        self._got = [0] * n
        self._expected = [0] * n
        self._synced = False
        # COB-ID -> (unpack_from, flat places, drive, bit, statusword's place or -1)
        self._dispatch: dict[int, tuple] = {}
        for d, drive in enumerate(drives):
            for k, pdo in enumerate(drive.tpdos):
                cols = pdo.columns()
                bit = 1 << k
                self._expected[d] |= bit
                sw = cols.index(STATUSWORD) if STATUSWORD in cols else -1
                self._dispatch[pdo.cob_id] = (
                    pdo.struct().unpack_from, tuple(d * N_TPDO_FIELDS + c for c in cols),
                    d, bit, sw)
            self._dispatch[EMCY_BASE + drive.node_id] = (
                struct.Struct("<HB5x").unpack_from, (), d, 0, -2)
        # the RPDOs: preallocated messages packed in place
        self.out = [[0] * 5 for _ in range(n)]
        self._rpdos: list[tuple[can.Message, struct.Struct, tuple[int, ...], list[int]]] = []
        for d, drive in enumerate(drives):
            for pdo in drive.rpdos:
                msg = can.Message(arbitration_id=pdo.cob_id, is_extended_id=False,
                                  data=bytearray(pdo.length))
                self._rpdos.append((msg, pdo.struct(), pdo.columns(), self.out[d]))
        self._sync = can.Message(arbitration_id=SYNC_COB_ID, is_extended_id=False, data=b"")

    # ------------------------------------------------------------------ receiving

    def drain(self, limit: int = 256) -> int:
        """Take every frame the bus holds now (at most ``limit``), without waiting;
        decode the drives' TPDOs and EMCYs. Returns the number of frames."""
        recv = self.bus.recv
        get = self._dispatch.get
        flat, got, sws = self._flat, self._got, self.statusword
        count = 0
        while count < limit:
            msg = recv(0.0)
            if msg is None:
                break
            count += 1
            entry = get(msg.arbitration_id)
            if entry is None:
                continue  # SYNC, RPDOs (ours, echoed), SDO, heartbeats, other nodes
            unpack, places, d, bit, sw = entry
            try:
                values = unpack(msg.data)
            except struct.error:
                self.bad_frames += 1
                continue
            if sw == -2:  # EMCY: error code and register
                self.emcy_code[d] = values[0]
                self.emcy_register[d] = values[1]
                continue
            for j in range(len(places)):
                flat[places[j]] = values[j]
            if sw >= 0:
                sws[d] = values[sw]
            got[d] |= bit
        self.frames += count
        return count

    def finish_cycle(self) -> None:
        """After a drain: which drives answered the last SYNC, which are stale."""
        synced, self._synced = self._synced, False
        got, expected, age = self._got, self._expected, self.age
        for d in range(self.n):
            if got[d] == expected[d]:
                age[d] = 0
            elif synced:
                a = age[d] = age[d] + 1
                self.stale[d] += 1
                if a > self.longest[d]:
                    self.longest[d] = a
            got[d] = 0

    def collect(self, timeout: float) -> bool:
        """Outside the loop only (bring-up, activation): wait up to ``timeout`` for every
        drive's TPDOs of the last SYNC. True if all came; the cycle is finished."""
        deadline = time.monotonic() + timeout
        got, expected = self._got, self._expected
        while True:
            self.drain()
            if got == expected:
                break
            left = deadline - time.monotonic()
            if left <= 0:
                break
            msg = self.bus.recv(timeout=min(left, 0.002))
            if msg is not None:
                self._one(msg)
        done = got == expected
        self.finish_cycle()
        return done

    def _one(self, msg: can.Message) -> None:
        """Dispatch one frame already taken (outside the loop)."""
        entry = self._dispatch.get(msg.arbitration_id)
        self.frames += 1
        if entry is None:
            return
        unpack, places, d, bit, sw = entry
        try:
            values = unpack(msg.data)
        except struct.error:
            self.bad_frames += 1
            return
        if sw == -2:
            self.emcy_code[d], self.emcy_register[d] = values[0], values[1]
            return
        for j in range(len(places)):
            self._flat[places[j]] = values[j]
        if sw >= 0:
            self.statusword[d] = values[sw]
        self._got[d] |= bit

    # -------------------------------------------------------------------- sending

    def send_rpdos(self) -> None:
        """Every drive's RPDOs from :attr:`out` (ints), packed in place, without waiting."""
        send = self.bus.send
        for msg, packer, cols, row in self._rpdos:
            if len(cols) == 3:
                packer.pack_into(msg.data, 0, row[cols[0]], row[cols[1]], row[cols[2]])
            elif len(cols) == 2:
                packer.pack_into(msg.data, 0, row[cols[0]], row[cols[1]])
            else:
                packer.pack_into(msg.data, 0, *[row[c] for c in cols])
            try:
                send(msg, 0.0)
            except can.CanError:
                self.send_errors += 1

    def send_sync(self) -> None:
        """SYNC: the drives apply the RPDOs and answer with their TPDOs."""
        try:
            self.bus.send(self._sync, 0.0)
        except can.CanError:
            self.send_errors += 1
            return
        self.syncs += 1
        self._synced = True
