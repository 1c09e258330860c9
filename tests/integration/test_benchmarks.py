"""The benchmarks run (in --quick mode): they must not rot. Their numbers are not checked."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("name", "printed"),
    [
        ("paper_evaluation", "ratio rtcf / cyclictest"),
        ("overhead", "ratio rtcf pure / plain"),
        ("scaling", re.compile(r"\| 1000 +\| 200 +\| pure ")),
        ("channels", "| mailbox try_read_into "),
        ("lanes", "| LET lane "),
        # all four rows, a ratio that is a number (a failed run prints "-"), the breakdown
        (
            "hot_path",
            re.compile(
                r"(?s)\| rtcf, compiled hot path .*\| rtcf, pure Python hot path .*"
                r"\| plain objects .*\| plain objects, timed per component .*"
                r"\| in one process, no sleep \(warm caches\) .*\| rtcf, compiled hot path +\| "
                r"\d+\.\d .*\| = rtcf, warm +\| \d+\.\d .*"
                r"verdict: rtcf's compiled hot path costs \d+\.\d+x plain objects"
            ),
        ),
    ],
)
def test_benchmark_runs_quick_and_writes_its_results(name, printed):
    docs = (ROOT / "docs" / "performance.md").read_text()
    result = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / f"{name}.py"), "--quick"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    if isinstance(printed, re.Pattern):
        assert printed.search(result.stdout), result.stdout
    else:
        assert printed in result.stdout, result.stdout
    data = json.loads((ROOT / "benchmarks" / "results" / f"{name}-quick.json").read_text())
    assert data  # raw numbers were written
    # --quick leaves the recorded results alone
    assert (ROOT / "docs" / "performance.md").read_text() == docs
