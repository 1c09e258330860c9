"""The cyclic exchange with the drives: frames drained without blocking, PDOs copied into
preallocated byte slots and read through numpy views; RPDOs sent from preallocated
messages filled from the same kind of views.

This is all of the bus work a Cia402System does in the loop. No thread receives:
``drain`` takes what the bus holds with python-can's ``recv(timeout=0)`` (one
non-blocking poll per frame, no filters in user space, since a frame a software filter
drops would end python-can's non-blocking ``recv`` early) and dispatches each frame by
its COB-ID through one dict look-up to its 8-byte slot, a memoryview the frame's bytes
are copied into. Nothing is decoded per frame: the slots of TPDO *k* of all the drives
lie 8 bytes apart, so each mapped object is one strided numpy view over them
(:attr:`Exchange.position` is every drive's actual position, as the drive sent it), which
the units then convert in one numpy call per interface. A drive whose TPDOs did not all
arrive since the last SYNC keeps its bytes, so its values stay as they were, and counts
a stale cycle (``age``: cycles since it was last complete, 0 when fresh; ``stale``: all
stale cycles); nothing waits for it. The RPDOs go the other way: targets written into
views over a transmit buffer, one slice copied into each preallocated message.

What python-can allocates per frame (its ``Message``; on udp_multicast also the msgpack
dict) is its own; rtcf keeps no object per cycle (tests/unit/canopen/test_exchange.py
counts them with tracemalloc).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import can
import can.typechecking
import numpy as np

# TPDO objects: the views of ``Exchange.tpdo``
STATUSWORD, MODE_DISPLAY, POSITION, VELOCITY, TORQUE, ERROR_CODE = range(6)
TPDO_FIELDS = {0x6041: STATUSWORD, 0x6061: MODE_DISPLAY, 0x6064: POSITION,
               0x606C: VELOCITY, 0x6077: TORQUE, 0x603F: ERROR_CODE}
# RPDO objects: the views of ``Exchange.rpdo``
CONTROLWORD, MODE, TARGET_POSITION, TARGET_VELOCITY, TARGET_TORQUE = range(5)
RPDO_FIELDS = {0x6040: CONTROLWORD, 0x6060: MODE, 0x607A: TARGET_POSITION,
               0x60FF: TARGET_VELOCITY, 0x6071: TARGET_TORQUE}
SYNC_COB_ID = 0x80
EMCY_BASE = 0x80
_DTYPES = {"B": "u1", "b": "i1", "H": "<u2", "h": "<i2", "I": "<u4", "i": "<i4"}
_SLOT = 8  # bytes per PDO slot: a classic CAN frame's data


@dataclass
class PdoLayout:
    """One PDO of one drive: its COB-ID and its fields as (object, struct code, byte
    offset), from the mapping canopen wrote to the drive."""

    cob_id: int
    fields: list[tuple[int, str, int]]
    length: int  # bytes


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
        self.age = np.zeros(n, np.int64)  # cycles since the drive's TPDOs last all arrived
        self.stale = np.zeros(n, np.int64)  # stale cycles, in all
        self.longest = np.zeros(n, np.int64)  # the longest run of stale cycles
        self.all_fresh = False  # every drive answered the last SYNC in full
        self.syncs = 0
        self.frames = 0  # frames drained, in all (ours echoed back and others included)
        self.bad_frames = 0  # a PDO shorter than its mapping, an EMCY not 8 bytes
        self.send_errors = 0  # a frame the bus refused (full, down): not retried
        self.emcy_seen = False  # an EMCY arrived since the flag was last cleared
        self.got = bytearray(n)  # per drive: a bit per TPDO arrived since the last SYNC
        self._expected = bytes(sum(1 << k for k in range(len(d.tpdos))) for d in drives)
        self._none = bytes(n)
        self._synced = False
        self._rx, self.tpdo = _slots(drives, "tpdos", TPDO_FIELDS)
        self._tx, self.rpdo = _slots(drives, "rpdos", RPDO_FIELDS)
        self._emcy = bytearray(_SLOT * n)
        self.emcy_code = np.ndarray((n,), "<u2", self._emcy, 0, (_SLOT,))
        self.emcy_register = np.ndarray((n,), "u1", self._emcy, 2, (_SLOT,))
        # COB-ID -> (the frame's slot, drive, its bit; 0 for an EMCY)
        rx, em = memoryview(self._rx), memoryview(self._emcy)
        self._dispatch: dict[int, tuple[memoryview, int, int]] = {}
        self._rpdos: list[tuple[can.Message, memoryview]] = []
        tx = memoryview(self._tx)
        for d, drive in enumerate(drives):
            for k, pdo in enumerate(drive.tpdos):
                at = (k * n + d) * _SLOT
                self._dispatch[pdo.cob_id] = (rx[at:at + pdo.length], d, 1 << k)
            self._dispatch[EMCY_BASE + drive.node_id] = (em[d * _SLOT:(d + 1) * _SLOT], d, 0)
            for k, pdo in enumerate(drive.rpdos):
                at = (k * n + d) * _SLOT
                msg = can.Message(arbitration_id=pdo.cob_id, is_extended_id=False,
                                  data=bytearray(pdo.length))
                self._rpdos.append((msg, tx[at:at + pdo.length]))
        self._sync = can.Message(arbitration_id=SYNC_COB_ID, is_extended_id=False, data=b"")
        # the views, by name (drives whose PDO lacks an object read 0 there)
        self.statusword = self.tpdo[STATUSWORD]
        self.position, self.velocity = self.tpdo[POSITION], self.tpdo[VELOCITY]
        self.torque = self.tpdo[TORQUE]
        self.controlword, self.mode = self.rpdo[CONTROLWORD], self.rpdo[MODE]
        self.target_position = self.rpdo[TARGET_POSITION]

    def filters(self) -> list[can.typechecking.CanFilter]:
        """python-can filters that pass the drives' TPDOs and EMCYs only: on socketcan
        the kernel applies them (CAN_RAW_FILTER), so the loop never sees another frame;
        on interfaces that filter in Python they would end a non-blocking drain early,
        so they are for socketcan only."""
        return [{"can_id": cob_id, "can_mask": 0x7FF, "extended": False}
                for cob_id in sorted(self._dispatch)]

    # ------------------------------------------------------------------ receiving

    def drain(self, limit: int = 256) -> int:
        """Take every frame the bus holds now (at most ``limit``), without waiting; copy
        the drives' TPDOs and EMCYs into their slots. Returns the number of frames."""
        recv = self.bus.recv
        get = self._dispatch.get
        got = self.got
        count = 0
        while count < limit:
            msg = recv(0.0)
            if msg is None:
                break
            count += 1
            entry = get(msg.arbitration_id)
            if entry is None:
                continue  # SYNC, RPDOs (ours, echoed), SDO, heartbeats, other nodes
            slot, d, bit = entry
            try:
                slot[:] = msg.data
            except ValueError:  # not the mapped length
                if not self._long(slot, msg.data):
                    continue
            if bit:
                got[d] |= bit
            else:
                self.emcy_seen = True
        self.frames += count
        return count

    def _long(self, slot: memoryview, data: bytearray) -> bool:
        """A frame longer than its mapping: its first bytes count (CiA 301); a shorter
        one is counted as bad and dropped."""
        if len(data) < len(slot):
            self.bad_frames += 1
            return False
        slot[:] = memoryview(data)[:len(slot)]
        return True

    def finish_cycle(self) -> None:
        """After a drain: which drives answered the last SYNC, which are stale."""
        synced, self._synced = self._synced, False
        got = self.got
        if got == self._expected:  # the common case: all answered, nothing to count
            if not self.all_fresh:
                self.all_fresh = True
                self.age.fill(0)
        elif synced or not self.all_fresh:
            self.all_fresh = False
            age, expected = self.age, self._expected
            for d in range(self.n):
                if got[d] == expected[d]:
                    age[d] = 0
                elif synced:
                    a = age[d] = age[d] + 1
                    self.stale[d] += 1
                    if a > self.longest[d]:
                        self.longest[d] = a
        got[:] = self._none

    def collect(self, timeout: float) -> bool:
        """Outside the loop only (bring-up, activation): wait up to ``timeout`` for every
        drive's TPDOs of the last SYNC. True if all came; the cycle is finished."""
        deadline = time.monotonic() + timeout
        while True:
            self.drain()
            if self.got == self._expected:
                break
            left = deadline - time.monotonic()
            if left <= 0:
                break
            msg = self.bus.recv(timeout=min(left, 0.002))
            if msg is not None:  # hand it back to the next drain's dispatch
                self._take(msg)
        done = self.got == self._expected
        self.finish_cycle()
        return done

    def _take(self, msg: can.Message) -> None:
        """Dispatch one frame already received (outside the loop)."""
        self.frames += 1
        entry = self._dispatch.get(msg.arbitration_id)
        if entry is None:
            return
        slot, d, bit = entry
        if len(msg.data) == len(slot):
            slot[:] = msg.data
        elif not self._long(slot, msg.data):
            return
        if bit:
            self.got[d] |= bit
        else:
            self.emcy_seen = True

    # -------------------------------------------------------------------- sending

    def send_rpdos(self) -> None:
        """Every drive's RPDOs as the :attr:`rpdo` views hold them, without waiting."""
        send = self.bus.send
        for msg, data in self._rpdos:
            msg.data[:] = data
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


def _slots(drives: Sequence[DriveLayout], which: str, objects: dict[int, int],
           ) -> tuple[bytearray, dict[int, np.ndarray]]:
    """A buffer of 8-byte slots (PDO *k* of drive *d* at slot ``k * n + d``) and, per
    mapped object, the view of every drive's value in it. The drives must map each
    object alike (same PDO, offset and type): ValueError naming the first that does
    not. An object no drive maps is an array of zeros."""
    n = len(drives)
    most = max((len(getattr(d, which)) for d in drives), default=0)
    buf = bytearray(_SLOT * n * max(1, most))
    where: dict[int, tuple[int, str, int, int]] = {}  # object -> (k, code, offset, node)
    for drive in drives:
        for k, pdo in enumerate(getattr(drive, which)):
            for obj, code, offset in pdo.fields:
                first = where.setdefault(obj, (k, code, offset, drive.node_id))
                if first[:3] != (k, code, offset):
                    raise ValueError(
                        f"node {drive.node_id} maps object {obj} of its {which[:-1].upper()}s "
                        f"unlike node {first[3]} (PDO {k + 1}, '{code}' at byte {offset}, "
                        f"not PDO {first[0] + 1}, '{first[1]}' at byte {first[2]}): give "
                        "the drives the same PDO mapping")
    views = {obj: np.zeros(n, np.int64) for obj in set(objects.values())}
    for obj, (k, code, offset, _) in where.items():
        views[obj] = np.ndarray((n,), _DTYPES[code], buf, k * n * _SLOT + offset, (_SLOT,))
    return buf, views
