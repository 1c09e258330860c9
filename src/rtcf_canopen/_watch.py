"""What a Cia402System's ``read`` decides from the drives' answers: a FAULT, a drive that
left OPERATION ENABLED, a drive that fell silent; each said once, in one line naming the
drive (node id, joint), the bus and what to do, through the hardware's logger (the
loop's log ring: nothing blocks)."""

from __future__ import annotations

import logging
from collections.abc import Sequence

from . import _cia402
from ._config import DriveConfig
from ._exchange import Exchange

_SILENT_AFTER = 10  # cycles without an answer before the warning


class DriveWatch:
    """The per-drive checks of one Cia402System's read, and its reports."""

    def __init__(self, logger: logging.Logger | logging.LoggerAdapter, hardware: str,
                 drives: Sequence[DriveConfig], bus: str, max_stale_cycles: int) -> None:
        self.log = logger
        self.hardware = hardware
        self.drives = list(drives)
        self.bus = bus
        self.max_stale_cycles = max_stale_cycles
        self._fault_logged = [False] * len(drives)
        self._silent_logged = [False] * len(drives)
        self._any_silent = False
        self._enabled = bytes([_cia402.OPERATION_ENABLED]) * len(drives)

    def who(self, d: int) -> str:
        return self.drives[d].name(self.bus)

    def check(self, ex: Exchange, active: bool, states: bytearray) -> bool:
        """After a drain: False if a drive is in FAULT, left OPERATION ENABLED while
        active, or has been silent for ``max_stale_cycles``; each said once. ``states``:
        the drives' CiA 402 states, a byte each (one comparison when all is well)."""
        if active and ex.all_fresh and states == self._enabled and not self._any_silent:
            return True
        sws, age, limit = ex.statusword, ex.age, self.max_stale_cycles
        ok = True
        for d in range(ex.n):
            sw = int(sws[d])
            if sw & 0x4F in (0x08, 0x0F):  # FAULT, FAULT REACTION ACTIVE
                if not self._fault_logged[d]:
                    self._fault_logged[d] = True
                    self._log_fault(ex, d, sw)
                ok = False
            elif active and age[d] == 0 and sw & 0x6F != 0x27:
                self.log.error(
                    "hardware '%s': %s left OPERATION ENABLED: it is %s (statusword "
                    "0x%04X); the hardware goes through on_error", self.hardware, self.who(d),
                    _cia402.STATE_NAMES[_cia402.state_of(sw)], sw)
                ok = False
            a = int(age[d])
            if a:
                if a == _SILENT_AFTER and not self._silent_logged[d]:
                    self._silent_logged[d] = True
                    self.log.warning(
                        "hardware '%s': %s has not answered SYNC for %d cycles; its last "
                        "values are kept and marked old (pdo_age)", self.hardware,
                        self.who(d), a)
                if limit and a >= limit:
                    self.log.error(
                        "hardware '%s': %s has not answered SYNC for %d cycles (%d stale in "
                        "all): check its power and wiring; the hardware goes through "
                        "on_error", self.hardware, self.who(d), a, ex.stale[d])
                    ok = False
            elif self._silent_logged[d]:
                self._silent_logged[d] = False
                self.log.info("hardware '%s': %s answers again (%d stale cycles in all)",
                              self.hardware, self.who(d), ex.stale[d])
        self._any_silent = any(self._silent_logged)
        return ok

    def not_in(self, ex: Exchange, target: int) -> str:
        """Which drives are not in state ``target``, with their statusword and EMCY
        code ("" when all are)."""
        return "; ".join(
            f"node {self.drives[d].node_id} is {_cia402.STATE_NAMES[s]} (statusword "
            f"0x{int(ex.statusword[d]):04X}{_code_text(ex, d)})"
            for d, s in enumerate(states_of(ex)) if s != target)

    def report(self, ex: Exchange) -> None:
        """The stale cycles per drive, since the bus was opened."""
        if not ex.syncs:
            return
        for d, drive in enumerate(self.drives):
            self.log.info(
                "hardware '%s': node %d: %d SYNCs, %d stale cycles (%.2f %%), longest %d",
                self.hardware, drive.node_id, ex.syncs, int(ex.stale[d]),
                100.0 * int(ex.stale[d]) / ex.syncs, int(ex.longest[d]))

    def missing(self, ex: Exchange, when: str) -> None:
        for d in range(ex.n):
            if ex.age[d]:
                self.log.warning("hardware '%s': %s sent no TPDO %s", self.hardware,
                                 self.who(d), when)

    def _log_fault(self, ex: Exchange, d: int, sw: int) -> None:
        code = int(ex.emcy_code[d])
        said = (f"error code 0x{code:04X} (error register 0x{int(ex.emcy_register[d]):02X}) from "
                "its EMCY" if code else "no EMCY received")
        self.log.error(
            "hardware '%s': %s is in FAULT (statusword 0x%04X, %s); the hardware goes "
            "through on_error: clear the cause, then configure and activate it again "
            "(set_hardware_component_state: the activation resets the fault)", self.hardware,
            self.who(d), sw, said)


def states_of(ex: Exchange) -> list[int]:
    """The drives' CiA 402 states (outside the loop)."""
    return [_cia402.state_of(int(sw)) for sw in ex.statusword]


def _code_text(ex: Exchange, d: int) -> str:
    code = int(ex.emcy_code[d])
    return f", EMCY error code 0x{code:04X}" if code else ""
