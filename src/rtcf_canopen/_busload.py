"""The CAN bus time a Cia402System's SYNC period needs, checked outside the loop.

Every SYNC period the bus carries the SYNC, each drive's RPDOs (sent only with the
SYNC: :meth:`Cia402System.write`) and each drive's TPDOs (transmission type 1: one
answer per SYNC), with the lengths the PDO mapping gave them. Their bits, worst case,
against the bits the bus's bitrate gives in the SYNC period:

* over 100 %: the configuration is refused (one line: the bus, the bitrate, the period,
  the bits needed and available, the drives, and what to do);
* over :data:`WARN_SHARE` (70 %): one warning. The 30 % left is for the frames this count
  leaves out (EMCYs, heartbeats, NMT, SDO diagnostics) and for an error frame and its
  retransmission, and because under CAN's arbitration the lowest-priority frame of a
  cycle (the last drive's TPDO) waits for all the others: near a full bus it arrives
  at the end of the period or in the next. Keeping a CAN bus's planned load well below
  full (commonly 50 to 70 %) is the usual margin for these reasons.

Interfaces with no bitrate of their own (python-can's ``virtual`` and ``udp_multicast``:
frames cost no bus time there) are not checked; the estimate is said once (info), as it
would be on a real bus at the configured ``bitrate``, so a description that will not fit
on the robot says so while it is still simulated.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ._exchange import DriveLayout

WARN_SHARE = 0.70
NO_BITRATE = ("virtual", "udp_multicast")  # python-can interfaces without bus time


def frame_bits(data_bytes: int) -> int:
    """Bits a classic CAN 2.0A data frame (11-bit identifier) with ``data_bytes`` bytes
    takes on the bus, with worst-case bit stuffing and the 3-bit interframe space.

    47 + 8 s bits (SOF, identifier, RTR, IDE, r0, DLC, data, CRC and its delimiter, ACK,
    EOF, interframe space) plus one stuff bit per 4 bits after the first of the 34 + 8 s
    bits that are stuffed (SOF to CRC): C = 8 s + 47 + floor((34 + 8 s - 1) / 4). This is
    the frame time of Davis, Burns, Bril and Lukkien, "Controller Area Network (CAN)
    schedulability analysis: refuted, revisited and revised", Real-Time Systems 35(3),
    2007, eq. (1), with g = 34 for 11-bit identifiers. A SYNC (0 bytes) is 55 bits, an
    8-byte frame 135."""
    stuffed = 34 + 8 * data_bytes
    return 8 * data_bytes + 47 + (stuffed - 1) // 4


@dataclass(frozen=True)
class BusLoad:
    """The frames of one SYNC period on one bus, worst case."""

    bits: int  # per SYNC period: SYNC, every RPDO and every TPDO
    drives: int
    frames: int

    @classmethod
    def of(cls, layouts: Sequence[DriveLayout]) -> BusLoad:
        lengths = [p.length for d in layouts for p in (*d.rpdos, *d.tpdos)]
        return cls(frame_bits(0) + sum(frame_bits(n) for n in lengths), len(layouts),
                   1 + len(lengths))

    def share(self, bitrate: int, period: float) -> float:
        """The share of the bus's bits in ``period`` (s) these frames take."""
        return self.bits / (bitrate * period)

    def check(self, bus: str, interface: str, bitrate: int, period: float,
              ) -> tuple[str, str]:
        """(level, line) for the SYNC period ``period`` (s): level ``error`` (it does not
        fit), ``warning`` (over :data:`WARN_SHARE`), ``info`` (fits; or an interface
        with no bitrate, where it is an estimate only)."""
        available = bitrate * period
        share = self.bits / available
        what = (f"bus {bus}: {self.drives} drive(s) need {self.bits} bits per SYNC period "
                f"(SYNC, {self.frames - 1} PDOs, worst-case bit stuffing) of the "
                f"{available:.0f} that {bitrate} bit/s gives in {period * 1e3:g} ms "
                f"({share:.0%})")
        if interface in NO_BITRATE:
            fit = ("would fit" if share <= WARN_SHARE else "would fit, with under "
                   f"{1 - WARN_SHARE:.0%} left" if share <= 1.0 else "would NOT fit")
            return "info", (f"{what}: {interface} has no bus time, so this is not checked; "
                            f"on a real bus at that bitrate it {fit}")
        if share > 1.0:
            least = self.bits / bitrate * 1e6
            return "error", (f"{what}: the bus is overloaded; raise sync_period to at least "
                             f"{least:.0f} µs (a whole number of loop periods), put "
                             "fewer drives on this bus (another Cia402System on another "
                             "bus), or map fewer PDOs (drop the velocity and effort state "
                             "interfaces)")
        if share > WARN_SHARE:
            return "warning", (f"{what}: over {WARN_SHARE:.0%}, little is left for EMCY, "
                               "heartbeats, SDO and retransmissions; consider a longer "
                               "sync_period or fewer drives per bus")
        return "info", what
