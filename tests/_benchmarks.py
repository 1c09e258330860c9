"""Running a benchmark's --quick mode from a test (integration and ROS 2 alike): its
numbers are not checked here, only that it runs and writes them."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "performance.md"


def run_quick(name, *args):
    """``benchmarks/NAME.py --quick ARGS``: its completed process and what it wrote to
    results/NAME-quick.json (None if it failed). --quick must leave the recorded results
    in docs/performance.md alone: asserted."""
    docs = DOCS.read_text()
    result = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / f"{name}.py"), "--quick", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
        stdin=subprocess.DEVNULL,
    )
    data = None
    if result.returncode == 0:
        data = json.loads((ROOT / "benchmarks" / "results" / f"{name}-quick.json").read_text())
    assert DOCS.read_text() == docs
    return result, data
