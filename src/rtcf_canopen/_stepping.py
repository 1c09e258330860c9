"""The CiA 402 state machines of a Cia402System's drives stepped with SYNC exchanges,
outside the loop: to OPERATION ENABLED on activate, to QUICK STOP ACTIVE and SWITCH ON
DISABLED on deactivate and in ``safe_stop``.

Each step sends every drive the controlword that takes it one transition toward the
target (:func:`._cia402.step_toward`), with SYNC, and waits (at most 20 ms) for the
answers; a drive already there is held.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from . import _cia402
from ._exchange import Exchange
from ._watch import DriveWatch, states_of


class Stepper:
    """Steps one exchange's drives toward a state; ``after_answers`` converts what came."""

    def __init__(self, ex: Exchange, watch: DriveWatch,
                 after_answers: Callable[[], None]) -> None:
        self.ex = ex
        self.watch = watch
        self.after_answers = after_answers

    def step_all(self, target: int, timeout: float) -> str:
        """"" when every drive is in ``target`` within ``timeout`` s, else which are not."""
        ex = self.ex
        deadline = time.monotonic() + timeout
        while True:
            ex.send_rpdos()
            ex.send_sync()
            ex.collect(0.02)
            self.after_answers()
            states = states_of(ex)
            if all(s == target for s in states):
                return ""
            if time.monotonic() > deadline:
                return self.watch.not_in(ex, target)
            cw = ex.controlword
            for d, s in enumerate(states):
                cw[d] = _cia402.step_toward(s, target, int(cw[d]))

    def safe_state(self, wait: bool) -> None:
        """Quick stop, then voltage off (``wait``: step until there, 0.5 s at most each;
        else the quick stop is sent once, not waited for)."""
        ex, log, name = self.ex, self.watch.log, self.watch.hardware
        for d, s in enumerate(states_of(ex)):
            ex.controlword[d] = _cia402.step_toward(s, _cia402.QUICK_STOP_ACTIVE)
        if not wait:
            ex.send_rpdos()
            ex.send_sync()
            return
        quick = self.step_all(_cia402.QUICK_STOP_ACTIVE, 0.5)
        if quick and "FAULT" not in quick:
            log.warning("hardware '%s': quick stop not confirmed: %s", name, quick)
        off = self.step_all(_cia402.SWITCH_ON_DISABLED, 0.5)
        if off and "FAULT" not in off:
            log.warning("hardware '%s': not SWITCH ON DISABLED: %s", name, off)
