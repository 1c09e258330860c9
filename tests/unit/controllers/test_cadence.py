"""rtcf_controllers._jtc_settings.Cadence: a rate from a controller's own runs, exact
on average where the period is no whole number of runs."""

from __future__ import annotations

import itertools

import pytest

from rtcf_controllers._jtc_settings import Cadence


def _due(cadence: Cadence, runs: int) -> list[int]:
    return [k for k in range(runs) if cadence.due(k)]


@pytest.mark.parametrize(
    ("rate", "frequency", "apart"),
    [
        (20.0, 1000.0, {50}),  # a whole number of runs: every 50th
        (20.0, 250.0, {12, 13}),  # 12.5 runs: 13, 12, 13, ...
        (30.0, 100.0, {3, 4}),  # 3.33 runs
        (500.0, 250.0, {1}),  # faster than the controller: every run
    ],
)
def test_runs_apart_and_the_rate_on_average(rate: float, frequency: float, apart: set) -> None:
    seconds = 10
    due = _due(Cadence.of(rate, frequency), int(frequency * seconds))
    assert due[0] == 0
    gaps = {b - a for a, b in itertools.pairwise(due)}
    assert gaps == apart
    assert len(due) == min(int(rate * seconds), int(frequency * seconds))
