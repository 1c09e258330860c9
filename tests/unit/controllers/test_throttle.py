"""rtcf_controllers._throttle: a problem logged once per occurrence, at most once a
second of the loop's time, the ones left out counted on the next record."""

from __future__ import annotations

import logging

import pytest

import rtcf
from rtcf.testing import run_components
from rtcf_controllers._throttle import Throttled


class Complains(rtcf.Component):
    """Says "bad <iteration>" in the iterations ~when lists (at 100 Hz)."""

    def configure(self) -> None:
        self.when = set(self.params.get("~when", []))
        self.bad = Throttled(self)

    def update(self) -> None:
        if self.iteration in self.when:
            self.bad.error("bad %d", self.iteration)


def test_repeats_within_a_second_are_counted_on_the_next_record(
    caplog: pytest.LogCaptureFixture,
) -> None:
    when = [0, 1, 2, 50, 100, 101, 350]  # 100 Hz: 0.0, ..., 1.0 s, 1.01 s, 3.5 s
    with caplog.at_level(logging.WARNING):
        run_components([rtcf.ComponentSpec("c", Complains, params={"when": when})], 400,
                       frequency=100.0)
    assert [r.getMessage() for r in caplog.records] == [
        "bad 0",
        "bad 100 (3 more like it since the last record)",
        "bad 350 (1 more like it since the last record)",
    ]
