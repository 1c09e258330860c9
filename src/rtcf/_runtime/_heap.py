"""The supervisor's heap: numpy's small-buffer cache filled at start, glibc's counters.

numpy keeps the data buffers of freed arrays smaller than 1024 bytes for reuse: up
to 7 per size in bytes, 1023 sizes (``NBUCKETS_DATA``/``NCACHE_DATA`` in
``numpy/_core/src/multiarray/alloc.c``; shapes and strides have a smaller cache of
the same kind). The cache never gives memory back, and it grows each time a size
turns up for the first time. The supervisor drains a different number of timing
rows each time it wakes, so its temporaries keep meeting new sizes: in the hour's
soak at 2 kHz that read as a leak of some 400 kB in the first minutes, still
creeping after an hour (docs/performance.md). Filling the cache once, before the
run, makes its size at start its size for good: at most 3.6 MB, the same
pre-allocation the worker does for its heap and stack, for the process that must
not grow either.
"""

from __future__ import annotations

import ctypes
from typing import Any

DATA_SIZES = 1024  # numpy caches data buffers of 1 .. DATA_SIZES - 1 bytes
DATA_PER_SIZE = 7
DIM_RANKS = 8  # shape + strides of 2 * ndim intp, cached for 2 * ndim < 16
DIM_PER_SIZE = 15

_filled = False


def fill_numpy_cache() -> None:
    """Fill numpy's caches of small buffers to their bound, once per process."""
    global _filled
    if _filled:
        return
    import numpy as np

    # held all at once, then freed: each size's bucket takes back as many as it keeps
    held: list[Any] = [
        np.empty(size, dtype=np.uint8)
        for size in range(1, DATA_SIZES)
        for _ in range(DATA_PER_SIZE)
    ]
    held += [
        np.empty((1,) * ndim, dtype=np.uint8)
        for ndim in range(1, DIM_RANKS)
        for _ in range(DIM_PER_SIZE)
    ]
    del held
    _filled = True


class _Mallinfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena", "ordblks", "smblks", "hblks", "hblkhd",
            "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost",
        )
    ]


def malloc_kb() -> dict[str, int]:
    """glibc's heap, all arenas (mallinfo2): ``in_use``, ``free`` inside it, ``arena``, in kB.

    A resident size that grows while ``in_use`` stays flat is the heap's
    fragmentation, not a leak. Empty where the C library lacks mallinfo2 (glibc
    before 2.33, musl).
    """
    try:
        fn = ctypes.CDLL(None).mallinfo2
    except AttributeError:
        return {}
    fn.restype = _Mallinfo2
    info = fn()
    return {
        "in_use": (info.uordblks + info.hblkhd) // 1024,
        "free": info.fordblks // 1024,
        "arena": info.arena // 1024,
    }
