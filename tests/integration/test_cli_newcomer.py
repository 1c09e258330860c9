"""What a newcomer met on a first run: a closed pipe, a report without matplotlib."""

import json
import os
import signal
import subprocess
import sys

import pytest

from .conftest import FIXTURES, SRC

pytestmark = pytest.mark.integration


def _env(*first: str) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([*first, str(SRC), str(FIXTURES)])
    return env


@pytest.mark.parametrize("fmt", ["text", "dot", "mermaid"])
def test_a_reader_that_goes_away_ends_the_command_quietly(fmt):
    # the reader closes its end before rtcf writes: every write meets EPIPE
    r, w = os.pipe()
    os.close(r)
    proc = subprocess.run(
        [sys.executable, "-m", "rtcf", "graph", "rtcf_examples", "complex_architecture.launch",
         "--format", fmt],
        stdout=w, stderr=subprocess.PIPE, text=True, env=_env(), timeout=60,
        stdin=subprocess.DEVNULL,
    )
    os.close(w)
    assert "Traceback" not in proc.stderr and "BrokenPipeError" not in proc.stderr, proc.stderr
    assert proc.returncode == 128 + signal.SIGPIPE


def test_report_without_matplotlib_says_so_at_start_and_writes_the_json(tmp_path):
    blocker = tmp_path / "block"
    (blocker / "matplotlib").mkdir(parents=True)
    # a matplotlib that cannot be found: the spec lookup fails as for a missing package
    (blocker / "sitecustomize.py").write_text(
        "import sys\n"
        "class _NoMatplotlib:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'matplotlib' or name.startswith('matplotlib.'):\n"
        "            raise ModuleNotFoundError(name)\n"
        "sys.meta_path.insert(0, _NoMatplotlib())\n"
    )
    (blocker / "matplotlib").rmdir()
    report = tmp_path / "report"
    proc = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", "rtcf_examples", "paper_example.launch",
         "--duration", "0.2", "--report", str(report), "--quiet"],
        capture_output=True, text=True, env=_env(str(blocker)), timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    note = next(i for i, line in enumerate(lines) if "matplotlib is not installed" in line)
    started = next(i for i, line in enumerate(lines) if "running 200 iterations" in line)
    assert note < started  # said before the loop ran, not after
    assert "pip install 'rtcf[plot]'" in lines[note]
    assert json.loads((report / "timing.json").read_text())["iterations"] == 200
    assert not (report / "timing.png").exists()
