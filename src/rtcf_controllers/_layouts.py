"""Views over an rtcf.Serialized's bytes that span several fields, for the loop.

A Serialized hands out one view per numeric field. Where a controller writes many
numbers that lie in a regular pattern in the bytes (the doubles of one
``SingleDOFState`` back to back, one ``InterfaceValue`` per joint a fixed stride
apart), one view over all of them turns many small stores into one numpy copy.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _address(view: np.ndarray) -> int:
    return int(view.__array_interface__["data"][0])


def _buffer(view: np.ndarray) -> Any:
    """The buffer a view was made from (a Serialized's bytearray)."""
    if view.base is None:
        raise ValueError("not a view into a buffer")
    return view.base


def _start(view: np.ndarray) -> int:
    """Where ``view`` starts in the buffer it was made from."""
    return _address(view) - _address(np.frombuffer(_buffer(view), dtype=np.uint8))


def run_from(first: np.ndarray, count: int) -> np.ndarray:
    """``count`` numbers of ``first``'s type from where ``first`` starts: the view of
    consecutive fields of one type (``reference`` .. ``output`` of a SingleDOFState)."""
    return np.ndarray((count,), dtype=first.dtype, buffer=_buffer(first), offset=_start(first))


def matrix(rows: list[np.ndarray]) -> np.ndarray:
    """Views of equal length, a fixed stride apart in one buffer, as one 2-D view."""
    base = _address(rows[0])
    stride = _address(rows[1]) - base if len(rows) > 1 else 0
    for j, row in enumerate(rows):
        if _address(row) != base + j * stride or len(row) != len(rows[0]):
            raise ValueError("the rows are not laid out a fixed stride apart")
    return np.ndarray((len(rows), len(rows[0])), dtype=rows[0].dtype, buffer=_buffer(rows[0]),
                      offset=_start(rows[0]), strides=(stride, rows[0].itemsize))
