"""WorkerRunner, the supervisor's handle on a worker, used from Python."""

import os

import pytest

import rtcf_examples
from rtcf import ComponentError, ComponentSpec, RunnerSettings
from rtcf._channels import leftover_segments
from rtcf._log import LogRecord
from rtcf._supervisor import WorkerDied, WorkerRunner

pytestmark = pytest.mark.integration


class Sink:
    def __init__(self) -> None:
        self.records: list[tuple[int, str, str, int]] = []

    def __call__(self, rec: LogRecord) -> None:
        self.records.append((rec.level, rec.logger, rec.format(), rec.iteration))


def test_load_run_unload_and_run_again_in_one_worker() -> None:
    sink = Sink()
    with WorkerRunner(RunnerSettings(frequency=100.0), simulated=True, log_sink=sink) as runner:
        assert runner.pid is not None and runner.pid != os.getpid()
        runner.load(ComponentSpec("log", rtcf_examples.Logging))  # a class: sent by name
        runner.load(ComponentSpec("bare", module="rtcf_examples", class_name="BareMinimum"))
        info = runner.describe()
        assert info["order"] == ["/bare", "/log"] and info["not_ready"] is None
        result = runner.run(3)
        assert result.iterations == 3 and result.stopped_by == "count"
        assert result.simulated and result.timing.iterations == 3
        assert result.order == ["/bare", "/log"]
        runner.unload("log")
        result = runner.run(2)
        assert result.order == ["/bare"] and result.iterations == 2
        assert runner.shutdown() == []
    rt = [r for r in sink.records if r[1] == "/log" and r[2].startswith("Test RT")]
    # Logging logs info/warning/error/fatal once per iteration, from the worker
    assert [r[3] for r in rt] == [0] * 4 + [1] * 4 + [2] * 4
    assert leftover_segments(os.getpid()) == []


def test_a_bad_load_is_refused_and_the_worker_lives_on() -> None:
    with WorkerRunner(RunnerSettings(frequency=100.0), simulated=True) as runner:
        with pytest.raises(ComponentError, match=r"'/ghost'.*no_such_module"):
            runner.load(ComponentSpec("ghost", module="no_such_module", class_name="X"))
        with pytest.raises(ComponentError, match="already loaded"):
            runner.load(ComponentSpec("a", rtcf_examples.BareMinimum))
            runner.load(ComponentSpec("a", rtcf_examples.BareMinimum))
        assert runner.run(1).iterations == 1  # still serving
        assert runner.shutdown() == []


def test_a_killed_worker_is_an_error_at_the_next_command() -> None:
    runner = WorkerRunner(RunnerSettings(frequency=100.0), simulated=True).start()
    try:
        assert runner.process is not None
        runner.process.kill()
        runner.process.wait()
        with pytest.raises(WorkerDied, match="was killed by SIGKILL"):
            runner.load(ComponentSpec("a", rtcf_examples.BareMinimum))
    finally:
        runner.close()
    assert leftover_segments(os.getpid()) == []
