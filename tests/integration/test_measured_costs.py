"""Spreading slow components by measured cost: rtcf launch --report, then
rtcf check --costs timing.json puts the expensive one first."""

import json

import pytest

from .._launches import launch_xml, launcher_xml, runner_xml
from .conftest import run_rtcf

pytestmark = pytest.mark.integration

LAUNCH = launch_xml(
    launcher_xml("a_cheap", "rtcf_test_components Busy", every=2)
    + launcher_xml("b_heavy", "rtcf_test_components Busy", every=2, busy_us=300),
    runner_xml(500.0, mode="wait_for_components", num_components_expected="2"),
)


def _phases(out):
    """component -> phase, from the plan table rtcf check prints."""
    rows = {}
    for line in out.splitlines():
        words = line.split()
        if len(words) == 5 and words[0].startswith("/"):
            rows[words[0]] = int(words[3])
    return rows


def test_the_measured_cost_decides_which_slow_component_goes_first(tmp_path):
    launch = tmp_path / "two.launch"
    launch.write_text(LAUNCH)
    declared = run_rtcf("check", launch)
    assert declared.returncode == 0, declared.stderr
    # no cost declared: both cost 1, and the name decides
    assert _phases(declared.stdout) == {"/a_cheap": 0, "/b_heavy": 1}
    run = run_rtcf("launch", launch, "--duration", "0.5", "--report", tmp_path / "report",
                   "--quiet")
    assert run.returncode == 0, run.stderr
    timing = json.loads((tmp_path / "report" / "timing.json").read_text())
    heavy = timing["components"]["/b_heavy"]["calc_us"]["p99"]
    assert heavy >= 300  # it spun that long, in the iterations it ran in
    measured = run_rtcf("check", launch, "--costs", tmp_path / "report" / "timing.json")
    assert measured.returncode == 0, measured.stderr
    assert _phases(measured.stdout) == {"/b_heavy": 0, "/a_cheap": 1}
    assert "costs from" in measured.stderr and "/b_heavy" in measured.stderr


def test_a_costs_file_that_is_not_a_report_is_one_clear_line(tmp_path):
    launch = tmp_path / "two.launch"
    launch.write_text(LAUNCH)
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    result = run_rtcf("check", launch, "--costs", bad)
    assert result.returncode == 1
    assert f"--costs {bad}: no 'components' section" in result.stderr
    result = run_rtcf("check", launch, "--costs", tmp_path / "none.json")
    assert result.returncode == 1
    assert "cannot read it: No such file or directory" in result.stderr
