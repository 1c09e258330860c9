"""The measurement behind issue 21's choice (not part of rtcf): what a chain of 200
trivial components costs per component with plain Python objects, with rtcf's ports
today, and with ports and an executor loop written against CPython's C API
(``_cports.c``, a prototype: Slot, a port with read/write, and a loop that calls each
update by vectorcall and stores its CLOCK_MONOTONIC time into a timing row).

    python benchmarks/prototypes/hot_path/bench.py

It builds ``_cports`` into a temporary directory first (a C compiler is needed).
"""

import array
import gc
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2] / "src"))

from rtcf._core._loop_state import LoopState  # noqa: E402
from rtcf._core._ports import InputPort, OutputPort  # noqa: E402


def build() -> None:
    out = tempfile.mkdtemp(prefix="cports-")
    setup = Path(out) / "setup.py"
    setup.write_text(
        "from setuptools import setup, Extension\n"
        f"setup(name='cports', ext_modules=[Extension('_cports', [{str(HERE / '_cports.c')!r}],"
        " extra_compile_args=['-O2'])])\n"
    )
    subprocess.run([sys.executable, str(setup), "build_ext", "--inplace", "-q"], cwd=out,
                   check=True, capture_output=True)
    sys.path.insert(0, out)


build()
import _cports  # noqa: E402

N = 200  # components in the chain
ITER = 2000  # iterations per measurement


class PlainSource:
    def __init__(self) -> None:
        self.value = 0.0

    def update(self) -> None:
        self.value += 1.0


class PlainGain:
    def __init__(self, src: object) -> None:
        self.src = src
        self.value = 0.0

    def update(self) -> None:
        self.value = self.src.value * 1.0001


class Source:
    def __init__(self, out: object) -> None:
        self.out = out
        self.v = 0.0

    def update(self) -> None:
        self.v += 1.0
        self.out.write(self.v)


class Gain:
    def __init__(self, port_in: object, out: object) -> None:
        self.port_in = port_in
        self.out = out

    def update(self) -> None:
        self.out.write((self.port_in.read() or 0.0) * 1.0001)


def plain() -> list:
    objs: list = [PlainSource()]
    for _ in range(N - 1):
        objs.append(PlainGain(objs[-1]))
    return [o.update for o in objs]


STATE = LoopState(500.0)


def python_ports() -> list:
    outs = [OutputPort("/s", "out", float, STATE)]
    comps: list = [Source(outs[0])]
    for _ in range(N - 1):
        port_in = InputPort("/g", "in", float)
        port_in._slot = outs[-1]._slot
        outs.append(OutputPort("/g", "out", float, STATE))
        comps.append(Gain(port_in, outs[-1]))
    return [c.update for c in comps]


C_STATE = _cports.State()


def c_ports() -> list:
    slots = [_cports.Slot() for _ in range(N)]
    comps: list = [Source(_cports.Port(slots[0], C_STATE))]
    for k in range(1, N):
        comps.append(Gain(_cports.Port(slots[k - 1]), _cports.Port(slots[k], C_STATE)))
    return [c.update for c in comps]


def bare_loop(updates: list) -> None:
    for _ in range(ITER):
        for update in updates:
            update()


def python_loop(updates: list) -> None:
    """The executor's per-component work as it is: running word, clock, timing row."""
    running = memoryview(bytearray(8)).cast("q")
    row = memoryview(bytearray(8 * (N + 8))).cast("q")
    now = time.monotonic_ns
    steps = tuple(enumerate(updates))
    for _ in range(ITER):
        t = now()
        for k, update in steps:
            running[0] = k
            update()
            t1 = now()
            row[6 + k] = t1 - t
            t = t1


def c_loop(updates: list) -> None:
    row = array.array("q", bytes(8 * (N + 8)))
    steps = tuple(updates)
    run = _cports.run_plan
    for _ in range(ITER):
        run(steps, row, 6)


def main() -> None:
    gc.disable()
    best: dict[tuple[str, str], float] = {}
    chains = (("plain objects", plain), ("rtcf ports (Python)", python_ports),
              ("C ports", c_ports))
    loops = (("bare for", bare_loop), ("executor loop (Python)", python_loop),
             ("executor loop (C)", c_loop))
    for _ in range(3):
        for chain, make in chains:
            updates = make()
            for name, loop in loops:
                t0 = time.perf_counter_ns()
                loop(updates)
                ns = (time.perf_counter_ns() - t0) / ITER / N
                best[chain, name] = min(best.get((chain, name), float("inf")), ns)
    for (chain, name), ns in best.items():
        print(f"{chain:22} {name:24} {ns:7.1f} ns/component")


if __name__ == "__main__":
    main()
