"""``rtcf launch`` with a lane on logical execution time: its values in the worker."""

from __future__ import annotations

import csv

from .._launches import let_launch
from .conftest import run_rtcf

LAUNCH = let_launch()  # /slow in lane mpc: every 10 from 3


def test_a_let_lane_reads_at_its_release_and_shows_at_the_next_window(tmp_path):
    launch = tmp_path / "let.launch"
    launch.write_text(LAUNCH)
    trace = tmp_path / "t.csv"
    done = run_rtcf("launch", launch, "--sim", "--duration", "0.05", "--trace", trace)
    assert done.returncode == 0, done.stderr
    assert "lanes: main (lock step): /sink, /src; mpc (LET, every 10; " in done.stderr
    assert "): /slow; each lane a worker process of its own" in done.stderr
    with open(trace) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 50
    x = [float(r["/x"]) for r in rows]
    for k, row in enumerate(rows):
        # released at 3, 13, 23, ...: reads /x as iteration r - 1 left it; visible r + 10
        releases = [r for r in range(3, k - 9, 10)]
        want = x[releases[-1] - 1] if releases else None
        assert (float(row["/y"]) if row["/y"] else None) == want, k
        # /sink copies /y in the same iteration (it is a lock-step reader)
        assert row["/z"] == row["/y"], k


def test_a_lane_that_mixes_rates_ends_with_one_line_naming_it(tmp_path):
    launch = tmp_path / "mixed.launch"
    launch.write_text(
        LAUNCH.replace('<param name="lane" value="mpc"/>', '<param name="lane" value="arm"/>')
        .replace(
            '<remap from="in_port" to="/y"/><remap from="out_port" to="/z"/>',
            '<remap from="in_port" to="/y"/><remap from="out_port" to="/z"/>'
            '<param name="lane" value="arm"/>',
        )
    )
    done = run_rtcf("launch", launch, "--sim", "--duration", "0.01")
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1, done.stderr
    assert "lane 'arm' mixes rates" in done.stderr and "every 10" in done.stderr


def test_graph_and_check_show_the_components_of_a_let_lane_and_no_internal_step(tmp_path):
    launch = tmp_path / "let.launch"
    launch.write_text(LAUNCH)
    for command in ("graph", "check"):
        done = run_rtcf(command, launch)
        assert done.returncode == 0, done.stderr
        rows = [line.split() for line in done.stdout.splitlines() if line.startswith("  /")]
        table = {row[0]: row[1:] for row in rows if len(row) > 1 and row[1][0] in ".x"}
        assert table == {
            "/slow": ["...x......", "10", "3", "1", "mpc", "(LET)"],
            "/sink": ["xxxxxxxxxx", "1", "0", "1", "main"],
            "/src": ["xxxxxxxxxx", "1", "0", "1", "main"],
        }, done.stdout
        assert "@" not in done.stdout, done.stdout
