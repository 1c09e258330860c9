"""timing.png: histograms of calculation time and jitter, drawn with matplotlib."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rtcf._cli._plot import MAX_DISPLAY_BINS, display_bins, format_us, plot_timing
from rtcf._core._errors import RtcfError
from rtcf._core._histogram import LogHistogram

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SRC = Path(__file__).resolve().parents[2] / "src"


def realistic() -> tuple[LogHistogram, LogHistogram]:
    rng = np.random.default_rng(3)
    n = 120_000
    calc = rng.lognormal(math.log(3_000), 0.15, n)
    calc[:5] = [19_000, 20_000, 20_500, 21_000, 22_000]
    jitter = rng.lognormal(math.log(25_000), 0.12, n)
    jitter[5:405] = 25_000 + rng.pareto(1.2, 400) * 20_000
    jitter = np.minimum(jitter, 1_000_000)
    hc, hj = LogHistogram(), LogHistogram()
    hc.add(calc.astype(np.int64))
    hj.add(jitter.astype(np.int64))
    return hc, hj


def image_size(path: Path) -> tuple[int, int]:
    from matplotlib import image

    pixels = image.imread(path)
    return pixels.shape[1], pixels.shape[0]


def test_writes_a_png_of_the_expected_size(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    calc, jitter = realistic()
    out = plot_timing(
        tmp_path / "timing.png", calc, jitter, title="2 kHz loop", subtitle="test machine, idle"
    )
    assert out == tmp_path / "timing.png"
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    width, height = image_size(out)
    assert abs(width - 11 * 110) <= 3 and abs(height - 4.5 * 110) <= 3


def test_empty_and_tiny_histograms_do_not_crash(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    one = LogHistogram()
    one.add_one(3_000)
    out = plot_timing(str(tmp_path / "empty.png"), LogHistogram(), one, title="nothing yet")
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    both = plot_timing(tmp_path / "both.png", LogHistogram(), LogHistogram(), title="t")
    assert both.read_bytes()[:8] == PNG_SIGNATURE


def test_missing_matplotlib_is_an_rtcf_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    calc, jitter = realistic()
    with pytest.raises(RtcfError) as info:
        plot_timing(tmp_path / "timing.png", calc, jitter, title="t")
    assert str(info.value) == (
        "timing.png needs matplotlib; install it with: pip install 'rtcf[plot]'"
    )
    assert not (tmp_path / "timing.png").exists()


def test_importing_the_modules_does_not_import_matplotlib() -> None:
    code = "import sys, rtcf._cli._plot, rtcf._core._histogram; print('matplotlib' in sys.modules)"
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        timeout=60,
    )
    assert done.stdout.strip() == "False"


def test_display_bins_keep_counts_exact() -> None:
    calc, jitter = realistic()
    for h in (calc, jitter):
        edges, counts = display_bins(h)
        assert counts.sum() == h.count
        assert len(edges) == len(counts) + 1 <= MAX_DISPLAY_BINS + 2
        assert edges[0] <= h.min / 1e3 and h.max / 1e3 <= edges[-1]
        assert np.allclose(np.diff(edges), edges[1] - edges[0])
    single = LogHistogram()
    single.add([5_000, 5_000])
    edges, counts = display_bins(single)
    assert counts.tolist() == [2] and edges[0] <= 5.0 <= edges[1]


def test_format_us() -> None:
    assert format_us(3.14159) == "3.14"
    assert format_us(12.34) == "12.3"
    assert format_us(456.7) == "457"
    assert format_us(1234.0) == "1234"


def test_each_lane_gets_a_row_of_its_own(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    calc, jitter = realistic()
    one = LogHistogram()
    one.add_one(4_000_000)
    out = plot_timing(
        tmp_path / "timing.png", calc, jitter, title="1 kHz loop and an MPC",
        lanes=[("lane right (lock step)", calc, jitter), ("lane mpc (LET, every 4)", one, one)],
    )
    width, height = image_size(out)
    assert abs(width - 11 * 110) <= 3
    assert abs(height - (4.5 + 2 * 3.6) * 110) <= 3  # two more rows of panels
