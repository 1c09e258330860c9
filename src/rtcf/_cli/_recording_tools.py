"""``rtcf diff`` and ``rtcf plot``: look at recordings of ``rtcf launch --record``.

``rtcf diff a.mcap b.mcap`` compares two recordings message by message: the same
topics, and on each topic the same messages (iteration, CDR bytes, and log time after
the file's first message, so that a replay of a real-time recording, stamped from 0,
can be identical to it), in the same order. It prints ``identical: ...`` and exits 0,
or the first topic and iteration that differ with both values decoded and exits 1
(like diff(1)); a file that is missing or not an MCAP exits 2. Metadata and
attachments are not compared: a replay differs from its recording there by design.

``rtcf plot run.mcap TOPIC...`` draws topics over time (seconds from the file's first
message) with matplotlib: one subplot per topic on a shared time axis, or all in one
with ``--overlay``. Values hold between writes (steps), as the components that read
them see them. ``--marks TOPIC`` draws a thin vertical line in every subplot where
TOPIC was written, as ticks along its bottom edge (a slow component's runs: when a
policy took its observation). Both read the file with :mod:`rtcf.recording` (the ``mcap`` packages:
``pip install 'rtcf[record]'``); plotting needs ``pip install 'rtcf[plot]'``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import re
import struct
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._core._errors import ConfigurationError, RtcfError
from .._runtime._recording import topic_pattern
from .._runtime._recording_reader import Message, Recording, Series, SeriesError, read

PLOT_HINT = "pip install 'rtcf[plot]'"


# --- reading -------------------------------------------------------------------


def _topic_filter(pattern: str, option: str) -> Callable[[str], bool]:
    regex = topic_pattern(pattern, option)
    return lambda topic: regex.fullmatch(topic) is not None


# --- comparing -----------------------------------------------------------------


@dataclass
class Difference:
    """The first difference on one topic."""

    topic: str
    iteration: int
    a: Message | None  # None: no message there in a
    b: Message | None


@dataclass
class Comparison:
    a: Recording
    b: Recording
    only_a: list[str]
    only_b: list[str]
    counts: dict[str, tuple[int, int]]  # topic -> (a, b), where they differ
    first: list[Difference]  # per differing topic, sorted by iteration then topic

    @property
    def identical(self) -> bool:
        return not (self.only_a or self.only_b or self.counts or self.first)


def _first_difference(
    topic: str, xs: list[Message], ys: list[Message], x0: int = 0, y0: int = 0
) -> Difference | None:
    """Walk both topics' messages by iteration; the first that is not in both alike
    (the same bytes logged at the same time after their file's start, ``x0`` or ``y0``)."""
    i = j = 0
    while i < len(xs) and j < len(ys):
        x, y = xs[i], ys[j]
        if x.iteration < y.iteration:
            return Difference(topic, x.iteration, x, None)
        if y.iteration < x.iteration:
            return Difference(topic, y.iteration, None, y)
        if x.log_time - x0 != y.log_time - y0 or x.data != y.data:
            return Difference(topic, x.iteration, x, y)
        i += 1
        j += 1
    if i < len(xs):
        return Difference(topic, xs[i].iteration, xs[i], None)
    if j < len(ys):
        return Difference(topic, ys[j].iteration, None, ys[j])
    return None


def compare(a: Recording, b: Recording) -> Comparison:
    only_a = sorted(set(a.messages) - set(b.messages))
    only_b = sorted(set(b.messages) - set(a.messages))
    common = sorted(set(a.messages) & set(b.messages))
    counts = {
        t: (len(a.messages[t]), len(b.messages[t]))
        for t in common
        if len(a.messages[t]) != len(b.messages[t])
    }
    first = []
    for topic in common:
        d = _first_difference(topic, a.messages[topic], b.messages[topic], a.start_ns, b.start_ns)
        if d is None and a.definition(topic) != b.definition(topic):
            d = Difference(topic, -1, None, None)  # the same bytes of another type
        if d is not None:
            first.append(d)
    first.sort(key=lambda d: (d.iteration, d.topic))
    return Comparison(a, b, only_a, only_b, counts, first)


def _leaves(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """(dotted path, value) of a decoded message's fields, depth first."""
    slots = getattr(value, "__slots__", None)
    if slots is not None and not isinstance(value, (str, bytes)):
        for name in slots:
            yield from _leaves(getattr(value, name), f"{path}.{name}" if path else name)
    elif isinstance(value, (list, tuple, np.ndarray)):
        yield f"{path}#len", len(value)
        for k, item in enumerate(value):
            yield from _leaves(item, f"{path}[{k}]")
    else:
        yield path, value


def _same(x: Any, y: Any) -> bool:
    if isinstance(x, float) and isinstance(y, float):
        return struct.pack("<d", x) == struct.pack("<d", y)  # -0.0 is not 0.0; NaN is NaN
    return bool(type(x) is type(y) and x == y)


def _field_difference(x: Any, y: Any) -> tuple[str, Any, Any] | None:
    """The first field of two decoded messages that differs: (path, value in x, in y)."""
    xs, ys = list(_leaves(x)), list(_leaves(y))
    for (px, vx), (py, vy) in zip(xs, ys, strict=False):
        if px != py:
            return px or py, vx, vy
        if not _same(vx, vy):
            if px.endswith("#len"):  # report the length, not its first element
                return f"len({px[:-4] or 'data'})", vx, vy
            return ("data" + px if px.startswith("[") else px), vx, vy
    if len(xs) != len(ys):
        return "", x, y
    return None


def _show(value: Any, other: Any = None) -> str:
    """A value for a human: 6 significant digits, all of them where that hides a change."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        short = f"{value:.6g}"
        if isinstance(other, float) and f"{other:.6g}" == short:
            return repr(value)
        return short
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        items = [_show(v) for v in list(value)[:6]]
        more = ", ..." if len(value) > 6 else ""
        return f"[{', '.join(items)}{more}] ({len(value)} elements)"
    return str(value)


def _describe(value: Any) -> Any:
    """A decoded std_msgs primitive as its data; other messages as they are."""
    slots = getattr(value, "__slots__", None)
    if slots is not None and "data" in slots and len([s for s in slots if s != "layout"]) == 1:
        return value.data
    return value


def describe_first(cmp: Comparison) -> str:
    """``first difference: TOPIC at iteration N (t = ... s): X in a, Y in b``."""
    d = cmp.first[0]
    a, b = cmp.a, cmp.b
    if d.iteration < 0:
        return (
            f"first difference: {d.topic} has the type {a.type_name(d.topic)} in {a.name} "
            f"and {b.type_name(d.topic)} in {b.name}"
        )
    stamp = d.a if d.a is not None else d.b
    assert stamp is not None
    where = (
        f"first difference: {d.topic} at iteration {d.iteration} "
        f"(t = {(a if d.a is not None else b).seconds(stamp.log_time):.6g} s)"
    )
    if d.a is None or d.b is None:
        rec, msg = (a, d.a) if d.a is not None else (b, d.b)
        assert msg is not None
        value = f"{_show(_describe(rec.decoder(d.topic)(msg.data)))} in {rec.name}"
        if d.a is not None:
            return f"{where}: {value}, no message in {b.name}"
        return f"{where}: no message in {a.name}, {value}"
    if d.a.data == d.b.data:  # the same value at another time
        return (
            f"{where}: the same value, logged at t = {a.seconds(d.a.log_time):.6g} s in "
            f"{a.name} and t = {b.seconds(d.b.log_time):.6g} s in {b.name}"
        )
    va = _describe(a.decoder(d.topic)(d.a.data))
    vb = _describe(b.decoder(d.topic)(d.b.data))
    found = _field_difference(va, vb)
    if found is None:
        text = f"{where}: the same decoded value {_show(va)}, other CDR bytes"
    elif found[0] == "":
        text = f"{where}: {_show(va)} in {a.name}, {_show(vb)} in {b.name}"
    else:
        path, x, y = found
        text = f"{where}: {path} = {_show(x, y)} in {a.name}, {_show(y, x)} in {b.name}"
    if a.seconds(d.a.log_time) != b.seconds(d.b.log_time):
        text += (
            f" (logged at t = {a.seconds(d.a.log_time):.6g} s and {b.seconds(d.b.log_time):.6g} s)"
        )
    return text


def format_comparison(cmp: Comparison) -> list[str]:
    a, b = cmp.a, cmp.b
    if cmp.identical:
        n = sum(len(m) for m in a.messages.values())
        return [f"identical: {len(a.messages)} topics, {n} messages"]
    lines = [f"{a.path} and {b.path} differ"]
    if cmp.first:
        lines.append(describe_first(cmp))
        if len(cmp.first) > 1:
            width = max(len(d.topic) for d in cmp.first)
            lines.append("first differing iteration per topic:")
            for d in cmp.first:
                at = "type" if d.iteration < 0 else str(d.iteration)
                lines.append(f"  {d.topic:<{width}}  {at}")
    for rec, only in ((a, cmp.only_a), (b, cmp.only_b)):
        if only:
            lines.append(f"only in {rec.name}: {', '.join(only)}")
    if cmp.counts:
        lines.append("message counts differ:")
        width = max(len(t) for t in cmp.counts)
        for topic, (na, nb) in cmp.counts.items():
            lines.append(f"  {topic:<{width}}  {na} in {a.name}, {nb} in {b.name}")
    same = sorted(set(a.messages) & set(b.messages) - {d.topic for d in cmp.first})
    if same and cmp.first:
        lines.append(f"identical topics: {len(same)} of {len(set(a.messages) | set(b.messages))}")
    for rec in (a, b):
        dropped = json.loads(rec.metadata.get("dropped", "{}") or "{}")
        if dropped:
            lines.append(
                f"note: {rec.name} lost {sum(dropped.values())} records (its rings were "
                "full), so a message missing there may not be a change"
            )
    return lines


def cmd_diff(ns: argparse.Namespace) -> int:
    try:
        select = _topic_filter(ns.topics, "--topics")
        a = read(ns.a, select)
        b = read(ns.b, select)
    except RtcfError as exc:
        if getattr(ns, "debug", False):
            raise
        print(f"rtcf: error: {exc}", file=sys.stderr)
        return 2
    if not ns.timing:  # the loop's timing rows are measurements, not signals
        timing = {r.metadata.get("timing_topic") for r in (a, b)} - {None, ""}
        for rec in (a, b):
            for topic in timing:
                rec.messages.pop(str(topic), None)
            # log times count from the first compared message: the timing rows' stamps
            # come from the supervisor's clock offset, a few µs from the worker's
            times = [x.log_time for msgs in rec.messages.values() for x in msgs]
            if times:
                rec.start_ns = min(times)
    cmp = compare(a, b)
    print("\n".join(format_comparison(cmp)))
    return 0 if cmp.identical else 1


# --- plotting ------------------------------------------------------------------


def series_of(rec: Recording, topic: str, field_path: str | None) -> Series:
    """A topic's numbers over time as the plot draws them (``values[k, j]``: line j at
    ``t_s[k]``, floats): ``field_path`` (dotted), default ``data`` where the message
    has it, else every number in it (but its header)."""
    try:
        s = rec.series(topic, field_path)
    except SeriesError as exc:
        if exc.fields is not None:
            raise ConfigurationError(
                f"--field {exc.field}: {topic} ({rec.type_name(topic)}) has no such field; "
                f"its fields: {', '.join(exc.fields)}"
            ) from None
        raise ConfigurationError(
            f"{topic} ({rec.type_name(topic)}): {exc.field or 'the message'} holds no numbers "
            "to plot" + ("" if field_path else "; choose a field with --field")
        ) from None
    labels = [""] if s.labels == ["data"] else s.labels  # a std_msgs primitive: the topic says it
    values = s.values.astype(np.float64).reshape(len(s), len(labels))
    return dataclasses.replace(s, labels=labels, values=values)


def resolve_topics(rec: Recording, wanted: list[str]) -> list[str]:
    """The topics named (or full-matched as a regex), in the order given, once each."""
    out: list[str] = []
    known = list(rec.messages)
    for word in wanted:
        if word in rec.messages:
            matches = [word]
        else:
            try:
                regex = re.compile(word)
            except re.error:
                matches = []
            else:
                matches = sorted(t for t in known if regex.fullmatch(t))
        if not matches:
            listing = ", ".join(sorted(known)) or "none"
            raise ConfigurationError(f"{rec.path} has no topic {word!r}; its topics: {listing}")
        out.extend(t for t in matches if t not in out)
    return out


def _title(rec: Recording) -> str:
    meta = rec.metadata
    parts = [rec.name]
    launch = meta.get("launch_file")
    if launch:
        args = " ".join(json.loads(meta.get("launch_arguments", "[]") or "[]"))
        parts.append(f"{Path(launch).name} {args}".strip())
    details = []
    if meta.get("frequency_hz"):
        details.append(f"{float(meta['frequency_hz']):g} Hz")
    if meta.get("iterations"):
        details.append(f"{int(json.loads(meta['iterations']))} iterations")
    if meta.get("simulated") == "true":
        details.append("simulated clock")
    if details:
        parts.append(", ".join(details))
    return ": ".join(parts[:2]) + (f" ({parts[2]})" if len(parts) > 2 else "")


def run_end_s(rec: Recording) -> float:
    """Where the time axis ends: the last message's iteration, held for one period."""
    end = rec.seconds(rec.end_ns)
    try:
        period = 1.0 / float(rec.metadata.get("frequency_hz", "nan"))
    except (ValueError, ZeroDivisionError):
        period = math.nan
    return end + period if period > 0 else end


def _rate(s: Series) -> str:
    """How many messages, and how often, where the interval is regular."""
    n = len(s.t_s)
    text = f"{n} message{'' if n == 1 else 's'}"
    if n > 2:
        gaps = np.diff(s.t_s)
        step = float(np.median(gaps))
        if step > 0 and np.allclose(gaps, step, rtol=1e-6, atol=1e-9):
            text += f", every {step * 1e3:.4g} ms ({1 / step:.4g} Hz)"
    return text


def _lines(
    ax: Any,
    s: Series,
    end_s: float,
    prefix: str,
    colors: list[str] | None = None,
    linestyle: str = "-",
) -> None:
    """Steps that hold each value until the next write, and the last one to ``end_s``;
    ``colors``: one per element (else the axes' cycle)."""
    t = s.t_s
    values = s.values
    if len(t) and t[-1] < end_s:
        t = np.append(t, end_s)
        values = np.vstack([values, values[-1:]])
    sparse = len(s.t_s) <= 60  # few writes: mark where they happened
    for j, label in enumerate(s.labels):
        name = f"{prefix} {label}" if prefix and label else (prefix or label)
        ax.plot(
            t,
            values[:, j],
            drawstyle="steps-post",
            linewidth=1.2,
            linestyle=linestyle,
            label=name or "_nolegend_",
            **({"color": colors[j % len(colors)]} if colors else {}),
        )
        if sparse:
            color = ax.lines[-1].get_color()
            ax.plot(
                s.t_s,
                s.values[:, j],
                linestyle="none",
                marker="o",
                markersize=3,
                color=color,
                label="_nolegend_",
            )


def draw(
    rec: Recording,
    series: list[Series],
    *,
    overlay: bool = False,
    figure: Any = None,
    marks: Series | None = None,
) -> Any:
    """A matplotlib Figure of ``series`` over a shared time axis (one subplot each, or
    all in one with ``overlay``); a new Agg figure unless ``figure`` is given;
    ``marks``: a vertical line in each subplot at each of its messages' times."""
    if figure is None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        rows = 1 if overlay else len(series)
        figure = Figure(figsize=(10.0, 1.2 + (4.0 if overlay else 2.1 * rows)), dpi=110)
        FigureCanvasAgg(figure)
    fig = figure
    axes = fig.subplots(1 if overlay else len(series), 1, sharex=True, squeeze=False)[:, 0]
    end_s = run_end_s(rec)
    from matplotlib import rcParams

    palette = list(rcParams["axes.prop_cycle"].by_key().get("color", ["tab:blue"]))
    for k, s in enumerate(series):
        ax = axes[0 if overlay else k]
        if not overlay:
            ax.set_prop_cycle(color=palette[k % len(palette) :] + palette[: k % len(palette)])
        if overlay and any(len(x.labels) > 1 for x in series):
            # arrays (joints): one colour per element, one line style per topic, so a
            # commanded and a measured joint share a colour
            _lines(ax, s, end_s, s.topic, palette, ("-", "--", ":", "-.")[k % 4])
        else:
            _lines(ax, s, end_s, s.topic if overlay else "")
        if not overlay:
            ax.set_title(s.topic, loc="left", fontsize=10, fontweight="bold")
            ax.set_title(f"{s.type_name}, {_rate(s)}", loc="right", fontsize=8, color="0.4")
            ax.set_ylabel(s.topic.rsplit("/", 1)[-1] or s.topic)
            if s.type_name == "std_msgs/msg/Bool":
                ax.set_yticks([0.0, 1.0], ["false", "true"])
            if len(s.labels) > 1:
                ax.legend(loc="best", fontsize=8, ncol=min(4, len(s.labels)))
    if marks is not None:
        label = f"{marks.topic} written ({len(marks.t_s)})"
        for ax in axes:
            # ticks along the bottom edge: the instants, without hatching the lines
            ax.vlines(marks.t_s, 0.0, 0.07, transform=ax.get_xaxis_transform(),
                      colors="0.25", linewidth=0.8, zorder=3, label=label)
            if not overlay:
                entries = len(ax.get_legend_handles_labels()[1])
                ax.legend(loc="best", fontsize=8, ncol=min(4, entries))
    if overlay:
        axes[0].set_ylabel("value")
        axes[0].legend(loc="best", fontsize=8)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, end_s)
    axes[-1].set_xlabel("time [s] (from the first message)")
    fig.suptitle(_title(rec), fontsize=11)
    fig.tight_layout()
    return fig


def _display_available() -> bool:
    if sys.platform.startswith("linux") or "bsd" in sys.platform:
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def plot_recording(
    path: str,
    topics: list[str],
    *,
    field_path: str | None = None,
    overlay: bool = False,
    figure: Any = None,
    marks: str | None = None,
) -> Any:
    """Read ``path`` and draw ``topics`` (names or full-match regexes): the Figure;
    ``marks``: a topic whose messages' times are marked in every subplot."""
    try:
        import matplotlib  # noqa: F401  (only: is it installed?)
    except ImportError:
        raise ConfigurationError(f"rtcf plot needs matplotlib: {PLOT_HINT}") from None
    rec = read(path)
    chosen = resolve_topics(rec, topics)
    series = [series_of(rec, t, field_path) for t in chosen]
    marked = None
    if marks is not None:
        topic = resolve_topics(rec, [marks])[0]
        marked = rec.series(topic) if rec.messages[topic] else None
    return draw(rec, series, overlay=overlay, figure=figure, marks=marked)


def cmd_plot(ns: argparse.Namespace) -> int:
    figure = None
    if ns.show:
        if not _display_available():
            raise ConfigurationError(
                "--show: no display ($DISPLAY is not set); write a PNG with -o FILE.png"
            )
        try:
            import matplotlib.pyplot as plt
        except ImportError:
            raise ConfigurationError(f"rtcf plot needs matplotlib: {PLOT_HINT}") from None
        figure = plt.figure(figsize=(10.0, 8.0))
    fig = plot_recording(
        ns.recording, ns.topics, field_path=ns.field, overlay=ns.overlay, figure=figure,
        marks=ns.marks,
    )
    if not ns.show or ns.output:
        out = ns.output or str(Path(ns.recording).with_suffix(".png"))
        try:
            fig.savefig(out, format="png")
        except OSError as exc:
            raise ConfigurationError(f"-o {out}: cannot write it: {exc.strerror}") from None
        print(f"rtcf: wrote {out}", file=sys.stderr)
    if ns.show:
        import matplotlib.pyplot as plt

        plt.show()
    return 0


# --- the command line ----------------------------------------------------------


def add_parsers(sub: Any, add_debug: Callable[[argparse.ArgumentParser], None]) -> None:
    diff = sub.add_parser(
        "diff",
        help="compare two recordings message by message (exit 0 identical, 1 differ)",
        description=(
            "Compare two recordings of rtcf launch --record (or rtcf replay): the same "
            "topics, and on each the same messages (iteration, bytes, log time from the "
            "file's first message). Prints "
            "the first topic and iteration that differ with both values. Exit status: 0 "
            "identical, 1 different, 2 bad input."
        ),
    )
    diff.add_argument("a", metavar="A.mcap")
    diff.add_argument("b", metavar="B.mcap")
    diff.add_argument(
        "--topics",
        default=".*",
        metavar="REGEX",
        help="compare only the topics this full-match regex matches",
    )
    diff.add_argument(
        "--timing",
        action="store_true",
        help="compare the runner's iteration_info too (measured timing: it differs "
        "between any two real-time runs, and a replay has none)",
    )
    diff.set_defaults(func=cmd_diff, log_level="warning")
    add_debug(diff)

    plot = sub.add_parser(
        "plot",
        help="plot recorded topics over time (PNG, or a window with --show)",
        description=(
            "Draw topics of a recording of rtcf launch --record over time, one subplot "
            "per topic on a shared time axis (seconds from the first message). Values "
            "hold between writes (steps); an array is one line per element."
        ),
    )
    plot.add_argument("recording", metavar="RECORDING.mcap")
    plot.add_argument(
        "topics", nargs="+", metavar="TOPIC", help="a topic, or a regex that full-matches topics"
    )
    plot.add_argument(
        "-o", "--output", metavar="PNG", help="where to write the PNG (default: RECORDING.png)"
    )
    plot.add_argument(
        "--field",
        metavar="NAME",
        help="the message field to plot, dotted (default: data where the "
        "message has it, else every number but the header)",
    )
    plot.add_argument("--overlay", action="store_true", help="all topics in one axes")
    plot.add_argument(
        "--marks",
        metavar="TOPIC",
        help="a vertical line in every subplot where TOPIC was written (e.g. a policy's "
        "observation: when it ran)",
    )
    plot.add_argument(
        "--show",
        action="store_true",
        help="open a window (needs a display); with -o, write the PNG too",
    )
    plot.set_defaults(func=cmd_plot, log_level="warning")
    add_debug(plot)
