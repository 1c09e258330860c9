"""The drives' device units and the joints' SI values: states from the TPDOs' raw values,
the RPDOs' targets from the commands.

``device = value * to_dev + offset_to_dev`` and ``value = device * from_dev +
offset_from_dev``, per drive and interface (the joints' ``scale_*``/``offset_*``
``<param>``s). Built once on configure over the hardware's own views, so that the loop
allocates nothing: numpy with ``out=`` arrays.
"""

from __future__ import annotations

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
_INT32 = (-(2**31), 2**31 - 1)
_INT16 = (-(2**15), 2**15 - 1)
_TPDO_COLUMN = {"position": POSITION, "velocity": VELOCITY, "effort": TORQUE}
_RPDO_FIELD = {"position": (TARGET_POSITION, _INT32), "velocity": (TARGET_VELOCITY, _INT32),
               "effort": (TARGET_TORQUE, _INT16)}


class Units:
    """Conversions between one Cia402System's drives and its interface values."""

    def __init__(self, hw: rtcf.SystemInterface, drives: Sequence[DriveConfig]) -> None:
        n = self.n = len(drives)
        self._states = {k: _view(hw.joints_with_state(k), hw.joint_states, k, drives)
                        for k in KINDS}
        self.commands = {k: _view(hw.joints_with_command(k), hw.joint_commands, k, drives)
                         for k in KINDS}
        self._extra = {k: hw.joint_states(k) for k in EXTRA_STATES}
        self._scale = {
            "position": (np.array([d.scale_pos_from_dev for d in drives]),
                         np.array([d.offset_pos_from_dev for d in drives]),
                         np.array([d.scale_pos_to_dev for d in drives]),
                         np.array([d.offset_pos_to_dev for d in drives])),
            "velocity": (np.array([d.scale_vel_from_dev for d in drives]), np.zeros(n),
                         np.array([d.scale_vel_to_dev for d in drives]), np.zeros(n)),
            "effort": (np.array([d.scale_eff_from_dev for d in drives]), np.zeros(n),
                       np.array([d.scale_eff_to_dev for d in drives]), np.zeros(n)),
        }
        self._tmp = np.empty(n)
        self._finite = np.empty(n, dtype=bool)
        self.targets = {k: np.zeros(n) for k in KINDS}  # device units, per drive

    @property
    def has_position(self) -> bool:
        return self._states["position"] is not None

    def to_states(self, ex: Exchange, active: bool) -> None:
        """The drives' raw values into the state interfaces (SI units); while not
        commanding, the position targets follow the drives (activation holds them)."""
        raw = ex.raw
        for kind in KINDS:
            view = self._states[kind]
            if view is None:
                continue
            values, where = view
            col = _TPDO_COLUMN[kind]
            frm, off, _, _ = self._scale[kind]
            if len(where) == ex.n:
                np.multiply(raw[:, col], frm, out=values)
                np.add(values, off, out=values)
            else:
                for j in range(len(where)):
                    d = where[j]
                    values[j] = raw[d, col] * frm[d] + off[d]
        extra = self._extra
        sw, st, age, stale, code = (extra["statusword"], extra["cia402_state"],
                                    extra["pdo_age"], extra["stale_cycles"], extra["error_code"])
        for d in range(ex.n):
            s = ex.statusword[d]
            sw[d] = s
            st[d] = _cia402.state_of(s)
            age[d] = ex.age[d]
            stale[d] = ex.stale[d]
            code[d] = ex.emcy_code[d]
        if active:
            return
        if self._states["position"] is not None:
            np.copyto(self.targets["position"], raw[:, POSITION])
            for d in range(ex.n):
                ex.out[d][TARGET_POSITION] = int(raw[d, POSITION])

    def to_targets(self, ex: Exchange) -> None:
        """The commands into the RPDOs' targets (device units, rounded, clamped to the
        object's range); a NaN command keeps the target it had."""
        out = ex.out
        for kind in KINDS:
            view = self.commands[kind]
            if view is None:
                continue
            field, bounds = _RPDO_FIELD[kind]
            values, where = view
            target = self.targets[kind]
            _, _, to_dev, off = self._scale[kind]
            tmp = self._tmp[:len(where)] if len(where) != ex.n else self._tmp
            np.multiply(values, to_dev[where] if len(where) != ex.n else to_dev, out=tmp)
            np.add(tmp, off[where] if len(where) != ex.n else off, out=tmp)
            np.isfinite(tmp, out=self._finite[:len(where)])
            np.clip(tmp, bounds[0], bounds[1], out=tmp)
            np.rint(tmp, out=tmp)
            if len(where) == ex.n:
                np.copyto(target, tmp, where=self._finite)
            else:
                for j in range(len(where)):
                    if self._finite[j]:
                        target[where[j]] = tmp[j]
            for d in range(ex.n):
                out[d][field] = int(target[d])

    def hold(self) -> None:
        """On activation: the commands start where the drives are (position) or at 0."""
        pos = self._states["position"]
        for kind, view in self.commands.items():
            if view is not None:
                if kind == "position" and pos is not None:
                    view[0][:] = pos[0]
                else:
                    view[0][:] = 0.0
        self.targets["velocity"][:] = 0.0
        self.targets["effort"][:] = 0.0


def _view(joints: Sequence[str], views: object, kind: str,
          drives: Sequence[DriveConfig]) -> tuple[np.ndarray, np.ndarray] | None:
    """(the joints' values of ``kind``, the drives they are), or None if no joint has it."""
    if not joints:
        return None
    where = np.array([i for i, d in enumerate(drives) if d.joint in joints], np.intp)
    return views(kind), where  # type: ignore[operator]
