"""The supervisor's heap stays put once numpy's small-buffer cache is filled.

Each case runs in a fresh interpreter: in this one, earlier tests have already put
buffers of many sizes into the cache, which would hide what filling it does.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from rtcf._runtime._heap import malloc_kb

pytestmark = pytest.mark.integration

# temporaries of the sizes the supervisor's drains make (a varying number of timing
# rows of 8-byte columns, masks of one byte a row), then what glibc holds in use
_CHURN = """
import collections, json, random, sys
import numpy as np
from rtcf._runtime._heap import fill_numpy_cache, malloc_kb
np.empty(8)  # numpy's first array allocates what every later one shares
if sys.argv[1] == "fill":
    fill_numpy_cache()
before = malloc_kb()["in_use"]
rnd = random.Random(1)
recent = collections.deque(maxlen=8)  # a few alive at once, as in a drain
for _ in range(50_000):
    n = rnd.randint(1, 1000)  # rows drained this time
    late = np.zeros(n, dtype=np.int64)[: n // 8 + 1] + 1
    recent.append((late, np.zeros(n, dtype=bool)))
recent.clear()
print(json.dumps({"growth_kb": malloc_kb()["in_use"] - before}))
"""


def _growth_kb(mode: str) -> int:
    out = subprocess.run(
        [sys.executable, "-c", _CHURN, mode], capture_output=True, text=True, check=True
    ).stdout
    return int(json.loads(out)["growth_kb"])


def test_small_temporaries_do_not_grow_the_heap_once_numpys_cache_is_filled() -> None:
    if not malloc_kb():
        pytest.skip("this C library has no mallinfo2 (glibc >= 2.33)")
    unfilled = _growth_kb("none")
    filled = _growth_kb("fill")
    # unfilled, the cache keeps buffers of every size it meets (what a soak saw as a
    # leak); filled, what is left is a few pages of glibc's own churn
    assert unfilled > 200, f"the control did not grow ({unfilled} kB): the test proves nothing"
    assert filled < 50, f"the heap grew by {filled} kB after fill_numpy_cache()"

