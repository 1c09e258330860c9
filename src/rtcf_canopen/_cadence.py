"""Which cycles of a Cia402System send the RPDOs and the SYNC, and the bus-load check.

SYNC goes out every n-th cycle, n = ``sync_period`` / the loop's period (at least 1).
The RPDOs go with it, just before it, and only then: every PDO is mapped synchronous
(transmission type 1, :mod:`._bringup`), and CiA 301 has a drive act on a synchronous
RPDO at the next SYNC only, so RPDOs between two SYNCs would only be overwritten in the
drive before it acts (bus time for nothing). The cycles in between still write the
newest targets into the transmit buffer (:meth:`Units.to_targets`): the RPDO sent with
the SYNC carries the newest, as the drive would have kept the newest.

The bus-load check (:mod:`._busload`) runs at configure for the SYNC period:
``sync_period``, else the hardware's ``info.rw_rate`` (the loop's rate unless the
``<ros2_control rw_rate>`` is slower, filled in by the resource manager as ros2_control
does), and refuses the configuration if the bus is overloaded. It runs again at the
first cycle if the period the loop gives there differs (a loop run at another rate than
it was configured for), and then an overloaded bus makes that cycle an ERROR (once,
before any SYNC of the loop; the hardware goes through on_error).
"""

from __future__ import annotations

import logging

from ._busload import BusLoad
from ._config import SystemConfig

_LEVELS = {"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}


class SyncCadence:
    """The SYNC every n-th cycle, n from the first cycle's period; the bus-load check."""

    def __init__(self, logger: logging.Logger | logging.LoggerAdapter, hardware: str,
                 config: SystemConfig, load: BusLoad) -> None:
        self.log = logger
        self.hardware = hardware
        self.config = config
        self.load = load
        self.every = 0  # SYNC every n-th cycle; 0: not known before the first cycle
        self.count = 0
        self.checked = 0.0  # the SYNC period (s) the load was checked for; 0: not yet

    def at_configure(self, rw_rate: int) -> bool:
        """The bus-load check if the SYNC period is known before the loop runs: from
        ``sync_period``, or the hardware's ``rw_rate``. False: overloaded (logged)."""
        sync = self.config.sync_period_us * 1e-6
        period = sync if sync > 0 else (1.0 / rw_rate if rw_rate > 0 else 0.0)
        return self._check(period) if period > 0 else True

    def tick(self, period: float) -> int:
        """Per cycle: 1 if this cycle sends the RPDOs and the SYNC, 0 if not, -1 if the
        first cycle found the bus overloaded (logged once)."""
        if not self.every and not self._start(period):
            return -1
        self.count += 1
        return 1 if self.count % self.every == 0 else 0

    def _start(self, period: float) -> bool:
        sync = self.config.sync_period_us * 1e-6
        self.every = max(1, round(sync / period)) if sync > 0 and period > 0 else 1
        actual = self.every * period
        if period > 0 and abs(actual - self.checked) > 1e-9:
            return self._check(actual)
        return True

    def _check(self, period: float) -> bool:
        bus = self.config.bus
        level, line = self.load.check(str(bus), bus.interface, bus.bitrate, period)
        self.log.log(_LEVELS[level], "hardware '%s': %s", self.hardware, line)
        self.checked = period
        return level != "error"
