"""rtcf evaluate: iteration_info read back from a recording, whatever its format."""

import numpy as np
import pytest

from rtcf._cli._evaluate import INTERVAL_DEVIATION, WAKE_UP_JITTER, evaluate, read_recording
from rtcf._cli._main import main
from rtcf._core._errors import RtcfError
from rtcf._core._iteration_records import IterationRecords

P = 5_000_000  # 200 Hz


def typed(stamps, calcs):
    return IterationRecords(
        "x.bag", "/rt_runner/iteration_info", "rtcf_msgs/IterationInfo",
        np.array(stamps, dtype=np.int64), np.array(calcs, dtype=np.int64),
    )  # fmt: skip


def test_the_originals_form_shows_how_far_each_start_to_start_interval_is_from_the_period():
    # starts on the grid plus a jitter; iteration 3 starts 7 ms late, 4 catches up
    jitter = [10_000, 12_000, 11_000, 7_000_000, 2_020_000, 13_000]
    stamps = [10**12 + k * P + j for k, j in enumerate(jitter)]
    ev = evaluate(typed(stamps, [20_000, 21_000, 6_000_000, 22_000, 23_000, 24_000]), 200.0)
    assert ev.starts_name == INTERVAL_DEVIATION
    expected = np.abs(np.diff(stamps) - P)
    assert ev.starts.count == 5
    assert (ev.starts.min, ev.starts.max) == (expected.min(), expected.max())
    assert ev.long_intervals == 1  # the late start
    assert ev.overruns == 1  # a calculation longer than a period
    assert (ev.calc.min, ev.calc.max) == (20_000, 6_000_000)
    assert ev.span_s == pytest.approx(5 * P / 1e9 + (13_000 - 10_000) / 1e9)
    assert ev.missing is None


def test_the_array_form_shows_the_wake_up_jitter_and_counts_missing_iterations():
    records = IterationRecords(
        "x.bag", "/r/iteration_info", "std_msgs/Float64MultiArray",
        stamp_ns=np.array([0, P, 3 * P, 4 * P], dtype=np.int64),
        calc_ns=np.array([1_000, 2_000, 3_000, 4_000], dtype=np.int64),
        jitter_ns=np.array([5_000, 6_000, 7_000, P], dtype=np.int64),
        iteration=np.array([10, 11, 13, 14], dtype=np.int64),
    )  # fmt: skip
    ev = evaluate(records, 200.0)
    assert ev.starts_name == WAKE_UP_JITTER
    assert (ev.starts.min, ev.starts.max, ev.starts.count) == (5_000, P, 4)
    assert ev.missing == 1
    assert ev.overruns == 1  # jitter + calculation beyond the period


def test_too_few_messages_is_an_error():
    with pytest.raises(RtcfError, match="holds 1 message; at least two"):
        evaluate(typed([0], [1]), 100.0)


def test_one_reader_per_format(tmp_path):
    with pytest.raises(RtcfError, match=r"run\.mcap: cannot read it: No such file"):
        read_recording(str(tmp_path / "run.mcap"))
    with pytest.raises(RtcfError, match=r"no reader for \.csv \(\.bag, \.mcap\)"):
        read_recording(str(tmp_path / "run.csv"))


def test_the_command_says_what_is_wrong(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path / "run.mcap"), "200"]) == 1
    assert "run.mcap: cannot read it" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["evaluate", "run.bag", "-5"])
    assert "not a positive frequency" in capsys.readouterr().err


def _timing_mcap(path, topics):
    """An MCAP file as rtcf launch --record writes it, with the timing rows of each topic."""
    from rtcf._core._timing import COL_CALC, COL_ITERATION, COL_JITTER, COL_SCHEDULED
    from rtcf._runtime._mcap import McapRecording

    rec = McapRecording(str(path))
    rec.begin([])
    for topic, rows in topics.items():
        rec.timing_topic = topic
        table = np.zeros((len(rows), 6), dtype=np.int64)
        for k, (it, scheduled, jitter, calc) in enumerate(rows):
            table[k, [COL_ITERATION, COL_SCHEDULED, COL_JITTER, COL_CALC]] = (
                it, scheduled, jitter, calc
            )
        rec.messages.setdefault(topic, 0)  # one runner per recording: a second by hand
        rec.timing_rows(table, offset_ns=10**9)
    if len(topics) > 1:
        rec.timing_topic = None  # the metadata names none: the reader must choose
    rec.finish({}, {})


def test_an_mcap_recording_gives_its_timing_rows(tmp_path):
    path = tmp_path / "run.mcap"
    _timing_mcap(path, {"/r/iteration_info": [(0, 0, 1500, 20_000), (1, P, 2500, 21_000)]})
    records = read_recording(str(path))
    assert records.topic == "/r/iteration_info"
    assert records.iteration.tolist() == [0, 1]
    assert records.stamp_ns.tolist() == [10**9, 10**9 + P]
    assert records.calc_ns.tolist() == [20_000, 21_000]
    assert records.jitter_ns.tolist() == [1500, 2500]


def test_an_mcap_with_two_runners_needs_a_topic(tmp_path):
    path = tmp_path / "two.mcap"
    _timing_mcap(path, {"/a/iteration_info": [(0, 0, 1, 2)], "/b/iteration_info": [(7, 0, 1, 2)]})
    with pytest.raises(RtcfError, match=r"two\.mcap: several iteration_info topics "
                       r"\(/a/iteration_info, /b/iteration_info\); pick one with --topic"):
        read_recording(str(path))
    assert read_recording(str(path), "/b/iteration_info").iteration.tolist() == [7]
