"""rtcf's C extensions where users install: a wheel built with a C compiler carries the
compiled hot path; one built without (CC fails) installs and runs the same loop in
Python, and says so in one warning line."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[2]
KEEP = ("src", "resource", "pyproject.toml", "setup.py", "README.md", "LICENSE", "package.xml")


def _wheel(tmp_path: Path, **env: str) -> Path:
    """A wheel of a copy of the sources (not of this checkout, whose build/ may hold
    extensions built before)."""
    src = tmp_path / "rtcf"
    src.mkdir()
    for name in KEEP:
        item = REPO / name
        if item.is_dir():
            shutil.copytree(item, src / name, ignore=shutil.ignore_patterns(
                "*.so", "__pycache__", "*.egg-info"))
        elif item.exists():
            shutil.copy2(item, src / name)
    out = tmp_path / "wheels"
    done = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
         "-w", str(out), str(src)],
        env={**os.environ, **env}, capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    (wheel,) = out.glob("rtcf-*.whl")
    return wheel


def _compiled_in(wheel: Path) -> list[str]:
    with zipfile.ZipFile(wheel) as z:
        return [n for n in z.namelist()
                if n.startswith("rtcf/_core/_compiled") and n.endswith(".so")]


def test_a_wheel_built_with_a_compiler_carries_the_compiled_hot_path(tmp_path: Path) -> None:
    names = _compiled_in(_wheel(tmp_path))
    assert len(names) == 1, names


def test_without_a_compiler_it_installs_runs_in_python_and_says_so_once(tmp_path: Path) -> None:
    wheel = _wheel(tmp_path, CC="false", CXX="false")  # every compiler call fails
    assert _compiled_in(wheel) == []
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(site)
    # this wheel's rtcf first, in the CLI and in its worker process (PYTHONPATH)
    env = {**os.environ, "PYTHONPATH": str(site)}
    env.pop("RTCF_PURE_PYTHON", None)
    done = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", "rtcf_examples", "paper_evaluation.launch",
         "--duration", "0.05"],
        env=env, capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    warnings = [line for line in done.stderr.splitlines() if "hot path" in line]
    assert len(warnings) == 2, done.stderr  # the warning, and the real-time line's path
    assert warnings[0].startswith("rtcf: warning: the loop's hot path runs in Python")
    assert "rtcf._core._compiled was not built" in warnings[0]
    assert "hot path in Python" in warnings[1]
