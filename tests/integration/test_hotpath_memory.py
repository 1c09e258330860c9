"""A million iterations of a loop whose components read, write and check their ports
every iteration: no memory grows (the hot path, compiled or not, leaks no reference).

A leak of one small object per iteration would be tens of MB here; the bound is 2 MB
(what a Python process's heap may move by on its own)."""

from __future__ import annotations

import gc

import pytest

import rtcf
from rtcf._core import _hotpath
from rtcf._core._clock import SimClock

pytestmark = pytest.mark.integration



class Source(rtcf.Component):
    def configure(self) -> None:
        self.out = self.add_output("x", float)
        self.value = 0.0

    def update(self) -> None:
        self.value += 0.5  # a new float object each iteration
        self.out.write(self.value)


class Gain(rtcf.Component):
    def configure(self) -> None:
        self.inp = self.add_input("x", float)
        self.out = self.add_output("y", float)

    def update(self) -> None:
        if self.inp.has_new_data and self.inp.status and self.inp.iteration >= 0:
            self.out.write((self.inp.read() or 0.0) * 2.0)


def _rss_kb() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 // 1024


def test_a_million_iterations_grow_no_memory() -> None:
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=1000.0), clock=SimClock(),
                         log_level="warning")
    runner.load(rtcf.ComponentSpec("src", cls=Source))
    runner.load(rtcf.ComponentSpec("gain", cls=Gain, remaps={"x": "/x", "y": "/y"}))
    runner.load(rtcf.ComponentSpec("gain2", cls=Gain, remaps={"x": "/y", "y": "/z"}))
    try:
        runner.run(50_000, drain_logs_every_iteration=False)  # warm: rings, histograms
        gc.collect()
        before = _rss_kb()
        result = runner.run(1_000_000, drain_logs_every_iteration=False)
        gc.collect()
        grown = _rss_kb() - before
    finally:
        runner.shutdown()
    assert result.iterations == 1_000_000
    assert grown < 2048, f"{grown} kB more after a million iterations ({_hotpath.describe()})"
