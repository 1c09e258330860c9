"""timing.png: histograms of calculation time and wake-up jitter (like Fig. 2 of the paper).

matplotlib is optional (``pip install 'rtcf[plot]'``) and imported only when a plot
is drawn, so importing rtcf never imports it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .._core._errors import RtcfError
from .._core._histogram import LogHistogram

MAX_DISPLAY_BINS = 200
WIDTH_IN, HEIGHT_IN, DPI = 11.0, 4.5, 110

_MISSING = "timing.png needs matplotlib; install it with: pip install 'rtcf[plot]'"


def format_us(value_us: float) -> str:
    """A microsecond value with 3 or 4 significant digits: 3.14, 12.3, 456, 1234."""
    if abs(value_us) >= 100:
        return f"{value_us:.0f}"
    if abs(value_us) >= 10:
        return f"{value_us:.1f}"
    return f"{value_us:.2f}"


def _nice_width(raw: float) -> float:
    """The smallest 1, 2 or 5 times a power of ten that is >= raw (> 0)."""
    exp = math.floor(math.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        w = m * 10.0**exp
        if w >= raw * (1 - 1e-12):
            return w
    return 10.0 ** (exp + 1)  # pragma: no cover - the loop always returns


def display_bins(
    hist: LogHistogram, max_bins: int = MAX_DISPLAY_BINS
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Rebin a histogram onto at most ``max_bins`` equal bins from min to max, in µs.

    Each bucket's count goes whole into the display bin that holds the bucket's
    middle (clamped to the exact min and max), so the counts add up exactly. The bin
    width is a round number (1, 2 or 5 times a power of ten) of µs. Returns the
    ``n + 1`` bin edges (µs) and the ``n`` counts.
    """
    assert hist.count > 0 and hist.min is not None and hist.max is not None
    lo_us, hi_us = hist.min / 1e3, hist.max / 1e3
    span = hi_us - lo_us
    width = _nice_width(max(span / max_bins, 1e-3))  # 1 ns is the finest resolution
    start = math.floor(lo_us / width) * width
    n = max(1, min(max_bins + 1, math.floor((hi_us - start) / width) + 1))
    edges = start + width * np.arange(n + 1, dtype=np.float64)
    lower, upper, counts = hist.nonzero()
    middle_us = np.clip((lower + upper - 1) / 2e3, lo_us, hi_us)
    idx = np.clip(np.floor((middle_us - start) / width).astype(np.int64), 0, n - 1)
    binned = np.bincount(idx, weights=counts.astype(np.float64), minlength=n)
    return edges, np.rint(binned).astype(np.int64)


def _panel(ax: Any, hist: LogHistogram, name: str, color: str) -> None:
    from matplotlib.ticker import NullFormatter

    ax.set_xlabel(f"{name} [µs]")
    ax.set_ylabel("count")
    ax.grid(True, which="major", alpha=0.3)
    if hist.count == 0 or hist.max is None:
        ax.set_title(f"{name} (no samples)")
        ax.text(
            0.5,
            0.5,
            "no samples",
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=12,
            color="0.4",
        )
        ax.set_xticks([])
        ax.set_yticks([])
        return
    ax.set_title(f"{name} ({hist.count:,} sample{'' if hist.count == 1 else 's'})")
    edges, counts = display_bins(hist)
    nz = counts > 0
    ax.bar(
        edges[:-1][nz],
        counts[nz],
        width=edges[1] - edges[0],
        align="edge",
        color=color,
        edgecolor=color,
        linewidth=0.4,
        log=True,
        label="_nolegend_",
    )
    p999_us = hist.quantile(0.999) / 1e3
    max_us = hist.max / 1e3
    # The dashed line is drawn over the solid one, so both show where they meet.
    ax.axvline(
        p999_us,
        color="tab:orange",
        linestyle="--",
        linewidth=1.6,
        zorder=3.1,
        label=f"99.9 %: {format_us(p999_us)} µs",
    )
    ax.axvline(
        max_us,
        color="tab:red",
        linestyle="-",
        linewidth=1.6,
        zorder=3,
        label=f"max: {format_us(max_us)} µs",
    )
    ax.set_yscale("log")
    # A single sample still shows as a bar from 0.5; the bars fill the lower 78 % of
    # the (log) height, leaving the top free for the legend.
    bottom, tallest = 0.5, float(counts.max())
    top = bottom * (tallest / bottom) ** (1 / 0.78)
    ax.set_ylim(bottom, max(top, tallest * 8.0, 20.0))
    ax.yaxis.set_minor_formatter(NullFormatter())  # labels on the decades only
    # Some room left and right so the lines at the extremes stay clear of the frame;
    # more when all samples (nearly) agree.
    pad = max(0.03 * (edges[-1] - edges[0]), 0.01 * abs(max_us), 0.01)
    ax.set_xlim(edges[0] - pad, edges[-1] + pad)
    # Anchored a little left of the right edge, so the max line stays visible there.
    ax.legend(loc="upper right", bbox_to_anchor=(0.95, 1.0), fontsize=9, framealpha=0.9)


def plot_timing(
    path: str | Path,
    calc: LogHistogram,
    jitter: LogHistogram,
    *,
    title: str,
    subtitle: str = "",
    names: tuple[str, str] = ("calculation time", "wake-up jitter"),
    lanes: list[tuple[str, LogHistogram, LogHistogram]] | None = None,
) -> Path:
    """Write a PNG with histograms of calculation time (left) and wake-up jitter (right).

    Counts are on a log scale; a dashed line marks the 99.9 % quantile and a solid
    one the maximum. ``subtitle`` is a smaller line under the title (machine,
    conditions); ``names`` label the two panels. ``lanes`` (a label, calculation and
    jitter of each lane) adds a row of both panels per lane, under the loop's.
    Raises :class:`RtcfError` if matplotlib is not installed.
    """
    try:
        import matplotlib  # noqa: F401  (only: is it installed?)
    except ImportError:
        raise RtcfError(_MISSING) from None
    # The object-oriented API with the Agg canvas needs no display and never touches
    # pyplot's global state or the process's chosen backend.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out = Path(path)
    rows = [("", calc, jitter)] + [(f"{label}: ", c, j) for label, c, j in lanes or []]
    if lanes:
        rows[0] = ("loop (all lanes in lock step): ", calc, jitter)
    n = len(rows)
    height = HEIGHT_IN + (n - 1) * (HEIGHT_IN - 0.9)
    fig = Figure(figsize=(WIDTH_IN, height), dpi=DPI)
    FigureCanvasAgg(fig)
    head_in = (HEIGHT_IN * (1 - (0.80 if subtitle else 0.86)))  # the title's room
    fig.subplots_adjust(left=0.065, right=0.985, bottom=0.55 / height,
                        top=1 - head_in / height, wspace=0.2, hspace=0.45 if n > 1 else 0.2)
    axes = fig.subplots(n, 2, squeeze=False)
    for (prefix, c, j), (left, right) in zip(rows, axes, strict=True):
        _panel(left, c, prefix + names[0], "tab:blue")
        _panel(right, j, prefix + names[1], "tab:green")
    fig.suptitle(title, fontsize=13, y=1 - 0.025 * HEIGHT_IN / height)
    if subtitle:
        fig.text(0.5, 1 - 0.105 * HEIGHT_IN / height, subtitle, ha="center", va="center",
                 fontsize=9, color="0.3")
    fig.savefig(out, dpi=DPI, format="png")
    fig.clear()
    return out
