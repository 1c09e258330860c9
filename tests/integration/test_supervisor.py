"""WorkerRunner, the supervisor's handle on a worker, used from Python."""

import os

import pytest

import rtcf_examples
from rtcf import ComponentError, ComponentSpec, RtcfError, RunnerSettings
from rtcf._core._log import LogRecord
from rtcf._runtime._supervisor import WorkerRunner
from rtcf._runtime._worker_process import WorkerDied

from .._proc import rtcf_shm_names

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
    assert rtcf_shm_names() == []


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
    assert rtcf_shm_names() == []


def test_a_parameter_set_while_running_applies_between_two_iterations(monkeypatch) -> None:
    """Two components read one tunable each; a change from another thread lands at an
    iteration boundary: no iteration sees the old value in one component and the new
    in the other, and every iteration after the change sees it."""
    import threading
    import time

    from .conftest import FIXTURES

    monkeypatch.syspath_prepend(str(FIXTURES))  # the worker imports from the same path
    sink = Sink()
    settings = RunnerSettings(frequency=200.0)
    with WorkerRunner(settings, log_sink=sink, name="tuning") as runner:
        runner.set_parameters({"/b/gain": 3.0})  # as a parameter server would hold it
        runner.load(ComponentSpec("a", module="rtcf_test_components", class_name="TunedLogger"))
        runner.load(ComponentSpec("b", module="rtcf_test_components", class_name="TunedLogger"))
        assert runner.introspect()["components"][1]["tunables"][0]["value"] == 3.0
        with pytest.raises(RtcfError, match=r"above its maximum 100\.0"):
            runner.set_parameter("/a", "gain", 1000.0)

        def change() -> None:
            time.sleep(0.25)
            runner.set_parameter("/a", "gain", 5.0)
            runner.set_parameter("/b", "gain", 5.0)

        t = threading.Thread(target=change)
        t.start()
        runner.run(120)  # 0.6 s
        t.join()
        runner.set_parameter("/a", "gain", 7.0)  # between runs: taken before the next
        runner.run(2)
        assert runner.shutdown() == []
    seen: dict[int, dict[str, str]] = {}
    for _, logger, text, iteration in sink.records:
        if text.startswith("gain"):
            seen.setdefault(iteration, {})[logger] = text.split()[1]
    assert sorted(seen) == list(range(122))
    first_new = min(i for i, v in seen.items() if v["/a"] == "5.0")
    assert 0 < first_new < 119
    for i in range(first_new, 120):
        assert seen[i] == {"/a": "5.0", "/b": "5.0"}, (i, seen[i])
    for i in range(first_new):
        assert seen[i] == {"/a": "1.0", "/b": "3.0"}, (i, seen[i])
    assert seen[120]["/a"] == "7.0" and seen[121]["/a"] == "7.0"


def test_a_parameter_a_component_sets_reaches_the_supervisors_store(monkeypatch):
    from .conftest import FIXTURES

    monkeypatch.syspath_prepend(str(FIXTURES))  # the worker imports from the same path
    settings = RunnerSettings(mode="no_wait", frequency=100.0)
    with WorkerRunner(settings, name="/rt_runner") as runner:
        runner.load(ComponentSpec("setter", module="rtcf_test_components",
                                  class_name="SetsParameters"))
        assert runner.parameters.get("/setter/calibrated") == 42.5
        assert runner.parameters.get("/shared/answer") == "yes"
