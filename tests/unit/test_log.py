"""The real-time safe log ring and the component logger."""

from __future__ import annotations

import logging

import pytest

from rtcf import LogLevel, RtcfError
from rtcf._core._log import (
    LOG_RECORD_SIZE,
    ComponentLogger,
    LogRecord,
    LogRing,
    LogWriter,
    PythonLoggingSink,
    drain_channel,
    python_logger_name,
)
from rtcf._core._loop_state import LoopState
from rtcf._core._rings import Ring


def _collect(ring: LogRing, limit: int | None = None) -> list[tuple]:
    out: list[tuple] = []
    ring.drain(lambda r: out.append((r.level, r.logger, r.format(), r.iteration, r.time_ns)), limit)
    return out


@pytest.mark.parametrize(("asked", "size"), [(1, 1), (3, 4), (4, 4), (5, 8), (4096, 4096)])
def test_capacity_is_a_power_of_two(asked: int, size: int) -> None:
    assert LogRing(asked).capacity == size


def test_push_and_drain_in_order() -> None:
    ring = LogRing(4)
    assert ring.push(20, "/a", "x=%d", (1,), 0, 10)
    assert ring.push(30, "/b", "plain", (), 1, 20)
    assert len(ring) == 2
    assert _collect(ring) == [(20, "/a", "x=1", 0, 10), (30, "/b", "plain", 1, 20)]
    assert len(ring) == 0
    assert ring.drain(lambda r: None) == 0


def test_full_ring_drops_and_counts() -> None:
    ring = LogRing(2)
    assert ring.push(20, "/a", "0", (), 0, 0)
    assert ring.push(20, "/a", "1", (), 0, 0)
    assert not ring.push(20, "/a", "2", (), 0, 0)
    assert not ring.push(20, "/a", "3", (), 0, 0)
    assert ring.dropped == 2
    assert [m for _, _, m, _, _ in _collect(ring)] == ["0", "1"]
    # room again after draining; the ring wraps around
    for i in range(5):
        assert ring.push(20, "/a", str(i), (), 0, 0)
        assert [m for _, _, m, _, _ in _collect(ring)] == [str(i)]
    assert ring.dropped == 2


def test_drain_limit() -> None:
    ring = LogRing(8)
    for i in range(5):
        ring.push(20, "/a", "%d", (i,), i, 0)
    assert [m for _, _, m, _, _ in _collect(ring, limit=2)] == ["0", "1"]
    assert len(ring) == 3
    assert [m for _, _, m, _, _ in _collect(ring)] == ["2", "3", "4"]


def test_drain_releases_arguments() -> None:
    ring = LogRing(2)
    ring.push(20, "/a", "%s", ([1],), 0, 0)
    ring.drain(lambda r: None)
    assert all(rec.args == () for rec in ring._records)


def test_bad_format_does_not_raise() -> None:
    rec = LogRecord()
    rec.msg = "%d"
    rec.args = ("x",)
    text = rec.format()
    assert "bad log format" in text
    assert "'%d'" in text


def test_component_logger_levels_and_loop_state() -> None:
    ring = LogRing(16)
    state = LoopState(10.0)
    state.iteration, state.time_ns = 7, 700
    log = ComponentLogger("/ns/c", ring, state)  # INFO by default
    log.debug("d")
    log.info("i %s", 1)
    log.warning("w")
    log.warn("w2")
    log.error("e")
    log.fatal("f")
    log.log(LogLevel.DEBUG, "ld")
    log.log(LogLevel.ERROR, "le")
    got = _collect(ring)
    assert [(lvl, m) for lvl, _, m, _, _ in got] == [
        (20, "i 1"), (30, "w"), (30, "w2"), (40, "e"), (50, "f"), (40, "le"),
    ]
    assert {(name, it, t) for _, name, _, it, t in got} == {("/ns/c", 7, 700)}


def test_set_level_by_name_and_number() -> None:
    ring = LogRing(16)
    log = ComponentLogger("/c", ring, LoopState())
    log.set_level("error")
    assert log.level == 40
    log.info("no")
    log.warning("no")
    log.error("yes")
    log.fatal("always")
    log.set_level(LogLevel.DEBUG)
    log.debug("dbg")
    assert [m for _, _, m, _, _ in _collect(ring)] == ["yes", "always", "dbg"]
    log.set_level(60)
    log.error("no")
    log.fatal("fatal is never filtered")
    assert [m for _, _, m, _, _ in _collect(ring)] == ["fatal is never filtered"]


def test_python_logger_name() -> None:
    assert python_logger_name("/ns/comp") == "rtcf.ns.comp"
    assert python_logger_name("/comp") == "rtcf.comp"


def test_python_logging_sink(caplog: pytest.LogCaptureFixture) -> None:
    ring = LogRing(8)
    ring.push(50, "/ns/c", "boom %d", (3,), 4, 0)
    ring.push(10, "/ns/c", "hidden", (), 4, 0)
    with caplog.at_level(logging.INFO, logger="rtcf"):
        ring.drain(PythonLoggingSink())
    assert [(r.name, r.levelno, r.getMessage()) for r in caplog.records] == [
        ("rtcf.ns.c", logging.CRITICAL, "boom 3")
    ]
    rec = caplog.records[0]
    assert rec.rtcf_component == "/ns/c"  # type: ignore[attr-defined]
    assert rec.rtcf_iteration == 4  # type: ignore[attr-defined]


# -- non-real-time logging (the original's NON_RT_* macros) -----------------------------
def _nonrt_logger(level: int = LogLevel.INFO) -> tuple[ComponentLogger, LoopState, list[tuple]]:
    state = LoopState()
    emitted: list[tuple] = []
    log = ComponentLogger(
        "/c", LogRing(4), state, level, emit=lambda *a: emitted.append(a)
    )
    return log, state, emitted


def test_nonrt_logs_at_once_with_the_formatted_text() -> None:
    log, state, emitted = _nonrt_logger()
    state.iteration, state.time_ns = 4, 99
    log.nonrt.info("gain=%.1f", 2.5)
    log.nonrt.warn("w")
    assert emitted == [(20, "/c", "gain=2.5", 4, 99), (30, "/c", "w", 4, 99)]


def test_nonrt_respects_the_level() -> None:
    log, _, emitted = _nonrt_logger(LogLevel.WARNING)
    log.nonrt.debug("d")
    log.nonrt.info("i")
    log.nonrt.error("e")
    log.set_level("debug")
    log.nonrt.debug("d2")
    assert [e[2] for e in emitted] == ["e", "d2"]


def test_nonrt_raises_while_the_loop_runs() -> None:
    log, state, emitted = _nonrt_logger(LogLevel.ERROR)
    state.running = True
    with pytest.raises(RtcfError, match=r"/c: self\.log\.nonrt\.info\(\) .* while the loop runs"):
        log.nonrt.info("filtered or not, it is a mistake in update")
    assert emitted == []
    log.info("the real-time logger is fine")  # filtered by level, but no error


def test_log_writer_round_trip_through_a_ring() -> None:
    ring = Ring.create(bytearray(Ring.nbytes(4, LOG_RECORD_SIZE)), 4, LOG_RECORD_SIZE)
    writer = LogWriter(ring)
    assert writer.push(30, "/ns/comp", "x=%d", (7,), 12, 3400)
    long_text = "é" * 2000
    assert writer.push(20, "/c", long_text, (), 13, 0)
    assert writer.push(20, "/c", "%d %d", (1,), 14, 0)  # a bad format is shown, not raised
    out: list[tuple] = []
    n = drain_channel(ring, lambda r: out.append((r.level, r.logger, r.format(), r.iteration)))
    assert n == 3
    assert out[0] == (30, "/ns/comp", "x=7", 12)
    assert out[1][2].endswith("[message cut: longer than a log record]")
    assert out[1][2].startswith("é" * 100)
    assert "bad log format" in out[2][2]
    for _ in range(4):
        writer.push(20, "/c", "fill", (), 0, 0)
    assert not writer.push(20, "/c", "one too many", (), 0, 0)
    assert writer.dropped == 1
    writer.release()
