"""The drives' device units and the joints' SI values: states from the TPDOs' views, the
RPDOs' targets from the commands.

``device = value * to_dev + offset_to_dev`` and ``value = device * from_dev +
offset_from_dev``, per drive and interface (the joints' ``scale_*``/``offset_*``
``<param>``s). Planned once on configure over the hardware's own views and the
exchange's, so that the loop allocates nothing and makes one numpy call or two per
interface, whatever the number of drives (a joint set that covers only some drives is
converted joint by joint in Python).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

import rtcf

from . import _cia402
from ._config import DriveConfig
from ._exchange import (
    POSITION,
    TARGET_POSITION,
    TARGET_TORQUE,
    TARGET_VELOCITY,
    TORQUE,
    VELOCITY,
    Exchange,
)

EXTRA_STATES = ("statusword", "cia402_state", "pdo_age", "stale_cycles", "error_code")
KINDS = ("position", "velocity", "effort")
_TPDO = {"position": POSITION, "velocity": VELOCITY, "effort": TORQUE}
_RPDO = {"position": (TARGET_POSITION, -(2**31), 2**31 - 1),
         "velocity": (TARGET_VELOCITY, -(2**31), 2**31 - 1),
         "effort": (TARGET_TORQUE, -(2**15), 2**15 - 1)}
_ENABLED_MASK, _ENABLED = 0x6F, 0x27  # statusword & mask == value: OPERATION ENABLED


def _scales(drives: Sequence[DriveConfig], kind: str) -> tuple[np.ndarray, ...]:
    """(from_dev, offset_from_dev, to_dev, offset_to_dev) per drive for ``kind``."""
    short = {"position": "pos", "velocity": "vel", "effort": "eff"}[kind]
    frm = np.array([getattr(d, f"scale_{short}_from_dev") for d in drives])
    to = np.array([getattr(d, f"scale_{short}_to_dev") for d in drives])
    if kind != "position":
        return frm, np.zeros(len(drives)), to, np.zeros(len(drives))
    return (frm, np.array([d.offset_pos_from_dev for d in drives]), to,
            np.array([d.offset_pos_to_dev for d in drives]))


class Units:
    """Conversions between one Cia402System's drives and its interface values."""

    def __init__(self, hw: rtcf.SystemInterface, drives: Sequence[DriveConfig],
                 ex: Exchange) -> None:
        n = self.n = len(drives)
        self.ex = ex
        self.targets = {k: np.zeros(n) for k in KINDS}  # device units, per drive
        self._reads: list[tuple] = []
        self._writes: list[tuple] = []
        self.commands: dict[str, np.ndarray] = {}
        self.has_position = bool(hw.joints_with_state("position"))
        # activation: each position command starts at its joint's actual position (NaN,
        # which holds the target, for a joint without a position state)
        with_state = list(hw.joints_with_state("position"))
        self._hold_from = [with_state.index(j) if j in with_state else -1
                           for j in hw.joints_with_command("position")]
        self._position_states = hw.joint_states("position") if with_state else None
        for kind in KINDS:
            frm, off_frm, to, off_to = _scales(drives, kind)
            joints = hw.joints_with_state(kind)
            if joints:
                where = np.array([i for i, d in enumerate(drives) if d.joint in joints], np.intp)
                dev = ex.tpdo[_TPDO[kind]]
                full = len(where) == n
                self._reads.append((
                    dev, None if full else where, np.empty(len(where), dev.dtype),
                    frm[where], off_frm[where] if off_frm.any() else None,
                    hw.joint_states(kind)))
            joints = hw.joints_with_command(kind)
            if joints:
                where = np.array([i for i, d in enumerate(drives) if d.joint in joints], np.intp)
                field, lo, hi = _RPDO[kind]
                values = self.commands[kind] = hw.joint_commands(kind)
                self._writes.append((
                    values, None if len(where) == n else where, to[where],
                    off_to[where] if off_to.any() else None, np.full(n, float(lo)),
                    np.full(n, float(hi)),
                    self.targets[kind], ex.rpdo[field]))
        self._tmp = np.empty(n)
        self._finite = np.empty(n, dtype=bool)
        self._extra = [hw.joint_states(k) for k in EXTRA_STATES]
        # the statuswords masked, in bytes: OPERATION ENABLED for all is one comparison
        self._mask = np.full(n, _ENABLED_MASK, np.uint16)
        self._masked_bytes = bytearray(2 * n)
        self._masked = np.frombuffer(self._masked_bytes, np.uint16)
        self._all_enabled = np.full(n, _ENABLED, np.uint16).tobytes()
        self.state_bytes = bytearray(n)  # the drives' CiA 402 states, one byte each
        self._state_view = np.frombuffer(self.state_bytes, np.uint8)
        self._states_shown = False  # the cia402_state interface says state_bytes
        self._counts_shown = False  # pdo_age and stale_cycles are up to date
        self._codes_shown = False

    def to_states(self, active: bool) -> None:
        """The drives' values into the state interfaces (SI units), their statusword,
        CiA 402 state, PDO age, stale cycles and EMCY code; while not commanding, the
        position targets follow the drives (so activation holds them)."""
        ex = self.ex
        for dev, where, tmp, frm, off, values in self._reads:
            if where is None:
                np.multiply(dev, frm, out=values)
            else:
                np.take(dev, where, out=tmp)
                np.multiply(tmp, frm, out=values)
            if off is not None:
                np.add(values, off, out=values)
        sw, state, age, stale, code = self._extra
        np.copyto(sw, ex.statusword)
        np.bitwise_and(ex.statusword, self._mask, out=self._masked)
        if self._masked_bytes != self._all_enabled or not self._states_shown:
            self._cia402_states(state)
        if not (ex.all_fresh and self._counts_shown):
            np.copyto(age, ex.age)
            np.copyto(stale, ex.stale)
            self._counts_shown = ex.all_fresh
        if ex.emcy_seen or not self._codes_shown:
            ex.emcy_seen = False
            self._codes_shown = True
            np.copyto(code, ex.emcy_code)
        if not active and self.has_position:
            np.copyto(self.targets["position"], ex.position)
            np.copyto(ex.target_position, ex.position, casting="unsafe")

    def _cia402_states(self, shown: np.ndarray) -> None:
        """Each drive's CiA 402 state from its statusword (when not all are OPERATION
        ENABLED: outside the loop, or a drive that left it)."""
        states = self.state_bytes
        for d, sw in enumerate(self.ex.statusword.tolist()):
            states[d] = _cia402.state_of(sw)
        np.copyto(shown, self._state_view)
        self._states_shown = self._masked_bytes == self._all_enabled

    def to_targets(self) -> None:
        """The commands into the RPDOs' targets (device units, rounded, clamped to the
        object's range); a command that is not finite keeps the target it had."""
        tmp, finite = self._tmp, self._finite
        for values, where, to, off, lo, hi, target, dev in self._writes:
            if where is None:
                np.multiply(values, to, out=tmp)
                if off is not None:
                    np.add(tmp, off, out=tmp)
                np.isfinite(tmp, out=finite)
                np.minimum(tmp, hi, out=tmp)
                np.maximum(tmp, lo, out=tmp)
                np.rint(tmp, out=tmp)
                np.copyto(target, tmp, where=finite)
            else:
                for j in range(len(where)):
                    v = float(values[j]) * to[j] + (0.0 if off is None else off[j])
                    if math.isfinite(v):
                        target[where[j]] = round(min(hi[0], max(lo[0], v)))
            np.copyto(dev, target, casting="unsafe")

    def hold(self) -> None:
        """On activation: the commands start where the drives are (position) or at 0."""
        for kind, values in self.commands.items():
            if kind != "position":
                values[:] = 0.0
            else:
                states = self._position_states
                for j, s in enumerate(self._hold_from):
                    values[j] = states[s] if s >= 0 and states is not None else np.nan
        self.targets["velocity"][:] = 0.0
        self.targets["effort"][:] = 0.0
