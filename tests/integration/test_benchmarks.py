"""The benchmarks run (in --quick mode): they must not rot. Their numbers are not checked."""

import importlib.util
import os
import re
import shutil

import pytest

from .._benchmarks import run_quick

pytestmark = pytest.mark.integration


@pytest.mark.parametrize(
    ("name", "printed"),
    [
        ("paper_evaluation", "ratio rtcf / cyclictest"),
        ("overhead", "ratio rtcf pure / plain"),
        ("scaling", re.compile(r"\| 1000 +\| 200 +\| pure ")),
        ("channels", "| mailbox try_read_into "),
        # every kind's row, and the float array's ring holding its 87,381 records
        ("recording", re.compile(r"(?s)\| float +\| \d+ .*\| float array, 3 elements .*\| 87381 ")),
        ("lanes", "| LET lane "),
        ("hardware_loop", re.compile(r"(?s)\| 96 +\| \d+\.\d+ +\| \d+\.\d+ .*\| plain +\| ")),
        # both networks' rows, bare and in the component; the loop inline and on LET
        (
            "policy",
            re.compile(
                r"(?s)\| small +\| Policy\.update .*\| large +\| onnxruntime bare .*"
                r"\| bytes kept per Policy\.update .*\| large inline \(main lane\) +\| \d+ .*"
                r"\| large on LET \(lane policy, every 20\) +\| \d+ +\| \d+ "
            ),
        ),
        # every system's row on both hot paths (a number in each column), and the fit
        (
            "command_limits",
            re.compile(
                r"(?s)\| \(a\) add_input, no check +\| 1 +\| 1 +\| \d+ .*"
                r"\| \(e\) position \+ max_velocity, clamped every iteration +\| 4 +\| 30 +\| "
                r"\d+ +\| [+-]\d+ +\| [+-]\d+ +\| \d+ +\| [+-]\d+ +\| [+-]\d+ +\|.*"
                r"\| \(b\) command input, no limits \(finite check\) +\| -?\d+ +\| -?\d+\.\d"
            ),
        ),
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
        # every path, drive count and scheduler measured (numbers, not "-"), the drives
        # answered on both paths (19 frames a cycle for 6 drives on rtcf's: 12 TPDOs and
        # its own 7 frames echoed), the plugin's own share, python-can's cost per frame
        pytest.param(
            "canopen_bus",
            re.compile(
                r"(?s)\| 1 +\| rtcf \(recv\(0\), no thread\) +\| OTHER +\| \d+\.\d .*"
                r"\| 6 +\| rtcf \(recv\(0\), no thread\) +\| FIFO 80 +\| \d+\.\d +(\| [^|]+ ){6}"
                r"\| 1[89]\.\d +\| .*"
                r"\| 6 +\| canopen Notifier thread +\| FIFO 80 +\| \d+\.\d .*"
                r"\| 6 +\| \d+\.\d +\| \d+\.\d +\| \d+\.\d .*"
                r"\| udp_multicast +\| \d+\.\d\d +\| \d+\.\d\d "
            ),
            marks=pytest.mark.skipif(
                os.geteuid() != 0 or shutil.which("unshare") is None
                or importlib.util.find_spec("canopen") is None,
                reason="needs root, unshare (a network namespace) and rtcf[canopen]"),
        ),
    ],
)
def test_benchmark_runs_quick_and_writes_its_results(name, printed):
    result, data = run_quick(name)  # and --quick leaves the recorded results alone
    assert result.returncode == 0, result.stdout + result.stderr
    if isinstance(printed, re.Pattern):
        assert printed.search(result.stdout), result.stdout
    else:
        assert printed in result.stdout, result.stdout
    assert data  # raw numbers were written
