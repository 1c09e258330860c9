"""The observation, assembled in place from the ports as the configuration says.

Each term's numbers are read from its port (``index`` picks elements), then
``(value - offset) * scale`` clipped to its ``clip``, into the term's newest history
row; older rows move up one (oldest first, IsaacLab's order); the first value fills
every row. ``clip_observations`` clips the whole. Everything is preallocated: views into
the model's bound input array, a float64 scratch row per term; assembling allocates no
array.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._config import PolicyConfig, Term


class _Filler:
    __slots__ = (
        "default",
        "filled",
        "high",
        "index",
        "low",
        "name",
        "offset",
        "port",
        "rows",
        "scale",
        "scratch",
        "source",
    )

    def __init__(self, term: Term, rows: tuple[np.ndarray, ...], port: Any,
                 source: np.ndarray | None) -> None:
        self.name = term.name
        self.port = port  # None: the previous action (source)
        self.source = source
        self.index = term.index
        self.default = term.default
        self.scale, self.offset, self.low, self.high = (
            term.scale, term.offset, term.low, term.high)
        self.scratch = np.zeros(term.size)
        self.rows = rows
        self.filled = False


class Observation:
    """``assemble()``: the observation of this moment into ``flat``; False (nothing
    written) while a port without a default has no value yet."""

    def __init__(self, config: PolicyConfig, flat: np.ndarray, ports: dict[str, Any],
                 last_action: np.ndarray) -> None:
        self.flat = flat
        self.clip = config.clip_observations
        self.low = -self.clip
        fillers = []
        at = 0
        for term in config.terms:
            rows = tuple(flat[at + k * term.size: at + (k + 1) * term.size]
                         for k in range(term.history))
            at += term.width
            fillers.append(_Filler(term, rows, ports.get(term.port) if term.port else None,
                                   last_action if not term.port else None))
        self.fillers = tuple(fillers)

    def reset(self) -> None:
        """Start afresh (``start``): histories refill from the first value."""
        for f in self.fillers:
            f.filled = False
        self.flat[:] = 0.0

    def assemble(self) -> bool:
        for f in self.fillers:
            if f.port is None:
                value: Any = f.source
            else:
                value = f.port.read()
                if value is None:
                    value = f.default
                    if value is None:
                        return False
            scratch = f.scratch
            try:
                if f.index is None:
                    np.copyto(scratch, value)
                elif type(value) is np.ndarray:
                    value.take(f.index, out=scratch)  # (the method: no Python wrapper)
                else:
                    np.take(value, f.index, out=scratch)
            except (ValueError, IndexError, TypeError):
                raise ValueError(_bad_value(f, value)) from None
            np.subtract(scratch, f.offset, out=scratch)
            np.multiply(scratch, f.scale, out=scratch)
            np.minimum(scratch, f.high, out=scratch)  # (ufuncs: np.clip's wrapper allocates)
            np.maximum(scratch, f.low, out=scratch)
            rows = f.rows
            if f.filled:
                for k in range(len(rows) - 1):  # one row up: oldest first
                    np.copyto(rows[k], rows[k + 1])
                np.copyto(rows[-1], scratch)
            else:
                for row in rows:
                    np.copyto(row, scratch)
                f.filled = True
        if self.clip != np.inf:
            np.minimum(self.flat, self.clip, out=self.flat)
            np.maximum(self.flat, self.low, out=self.flat)
        return True


def _bad_value(f: _Filler, value: Any) -> str:
    shape = getattr(value, "shape", type(value).__name__)
    want = (f"{len(f.scratch)} numbers" if f.index is None
            else f"elements {f.index.tolist()}")
    return (f"observation term {f.name!r}: port {f.port.name!r} gave a value of shape "
            f"{shape}; the term reads {want}")
