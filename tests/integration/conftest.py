import subprocess
import sys
from pathlib import Path

import pytest

from .._proc import env_with

FIXTURES = Path(__file__).parent / "fixtures"
SRC = Path(__file__).resolve().parents[2] / "src"


def run_rtcf(*args, timeout=120, cwd=None):
    env = env_with(FIXTURES)
    return subprocess.run(
        [sys.executable, "-m", "rtcf", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
    )


@pytest.fixture
def rtcf_cli():
    return run_rtcf
