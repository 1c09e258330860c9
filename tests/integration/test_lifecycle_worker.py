"""Lifecycle transitions through the worker/supervisor pair, without any middleware.

A transition asked for in the supervisor (from any thread) crosses to the worker as
an update record, is applied at the start of an iteration while the loop runs on,
and its outcome comes back on a ring of its own.
"""

from __future__ import annotations

import csv
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from rtcf import ComponentSpec, RtcfError, RunnerSettings
from rtcf._core._executor import CONTROL
from rtcf._core._faults import FailurePolicy
from rtcf._core._lifecycle import TransitionOutcome
from rtcf._core._log import LogRecord
from rtcf._runtime._requests import Request, RequestQueue, serve_request
from rtcf._runtime._supervisor import WorkerRunner

from .._proc import rtcf_shm_names
from .conftest import FIXTURES

pytestmark = pytest.mark.integration

FREQUENCY = 200.0
PERIOD_NS = round(1e9 / FREQUENCY)


class Sink:
    def __init__(self) -> None:
        self.records: list[tuple[int, str, str, int]] = []

    def __call__(self, rec: LogRecord) -> None:
        self.records.append((rec.level, rec.logger, rec.format(), rec.iteration))


@pytest.fixture(autouse=True)
def _fixtures_on_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(FIXTURES))  # the worker imports from the same path


def load_pair(runner: WorkerRunner, **follower_params: Any) -> None:
    mod = "rtcf_lifecycle_components"
    runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
    runner.load(ComponentSpec("follower", module=mod, class_name="Follower",
                              params=follower_params))


def wait_until(condition: Any, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_deactivate_and_activate_while_the_loop_runs(tmp_path: Path) -> None:
    sink = Sink()
    trace = tmp_path / "trace.csv"
    heard: list[tuple[str, str, bool]] = []
    outcomes: list[TransitionOutcome] = []
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY), log_sink=sink) as runner:
        runner.transition_listeners.append(
            lambda name, o: heard.append((name, o.label, o.ok))
        )
        load_pair(runner)
        assert runner.lifecycle_state("/follower") == "inactive"  # configured, not started

        def operate() -> None:
            try:
                wait_until(lambda: runner.loop_running and runner.live_status().iterations > 20)
                outcomes.append(runner.change_state("/follower", "deactivate"))
                time.sleep(0.25)
                outcomes.append(runner.change_state("/follower", "activate"))
                time.sleep(0.15)
            finally:
                runner.request_stop()

        t = threading.Thread(target=operate)
        t.start()
        result = runner.run(None, trace=str(trace))
        t.join()
        assert runner.lifecycle_state("/follower") == "active"
        assert runner.introspect()["components"][1]["lifecycle"] == "active"
        assert runner.shutdown() == []
    assert [(o.ok, o.label, o.end_label) for o in outcomes] == [
        (True, "deactivate", "inactive"), (True, "activate", "active"),
    ]
    # the runner's activation at the start, then the two transitions
    assert heard == [("/ramp", "activate", True), ("/follower", "activate", True),
                     ("/follower", "deactivate", True), ("/follower", "activate", True)]
    with trace.open() as f:
        rows = [(int(r["iteration"]), int(r["time_ns"]), float(r["/x"]), float(r["/y"]))
                for r in csv.DictReader(f)]
    # the loop never stopped: every iteration, on the grid of the first
    assert [(i, t) for i, t, _, _ in rows] == [(i, i * PERIOD_NS) for i in range(len(rows))]
    followed = [y == x + 1000.0 for _, _, x, y in rows]
    off = [i for i, ok in enumerate(followed) if not ok]
    assert off, "the follower never stopped writing"
    first, last = off[0], off[-1]
    assert off == list(range(first, last + 1))  # one gap, then it follows again
    assert last - first + 1 >= 0.2 * FREQUENCY  # about the 0.25 s it was inactive
    assert all(y == rows[first - 1][3] for _, _, _, y in rows[first : last + 1])  # old value
    assert followed[-1]
    # its timing counts only the iterations it ran in
    assert result.aggregate is not None
    counts = {n: len(h) for n, h in result.aggregate.components.items()}
    assert counts["/ramp"] == len(rows) and counts["/follower"] == len(rows) - len(off)
    stops = [r for r in sink.records if r[1] == "/follower" and r[2].startswith("stop at")]
    # the deactivation's, in the iteration it took effect; then shutdown's, after the last
    assert [r[2] for r in stops] == [f"stop at iteration {first}",
                                     f"stop at iteration {len(rows) - 1}"]
    assert rtcf_shm_names() == []


def test_a_switch_lands_in_one_iteration_deactivations_first(tmp_path: Path) -> None:
    """``change_states`` (a controller manager's switch): the worker reads every
    transition of the batch at the start of one iteration, so the output that one
    follower stops writing the other writes from the very same iteration on."""
    sink = Sink()
    trace = tmp_path / "trace.csv"
    outcomes: list[TransitionOutcome] = []
    mod = "rtcf_lifecycle_components"
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY), simulated=True,
                      log_sink=sink) as runner:
        runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
        for name in ("a", "b"):
            runner.load(ComponentSpec(name, module=mod, class_name="Follower",
                                      remaps=[("y", f"y_{name}")]))
        runner.run(2)
        assert runner.change_state("/b", "deactivate").ok  # between runs: at once

        def operate() -> None:
            try:
                wait_until(lambda: runner.loop_running and runner.live_status().iterations > 20)
                outcomes.extend(runner.change_states([("/a", "deactivate"), ("/b", "activate")]))
                wait_until(lambda: runner.live_status().iterations > 60)
            finally:
                runner.request_stop()

        t = threading.Thread(target=operate)
        t.start()
        runner.run(None, trace=str(trace))
        t.join()
        assert [runner.lifecycle_state(n) for n in ("/a", "/b")] == ["inactive", "active"]
        assert runner.shutdown() == []
    assert [(o.ok, o.label, o.end_label) for o in outcomes] == [
        (True, "deactivate", "inactive"), (True, "activate", "active"),
    ]
    # the deactivation's hook first, then the activation's, in the same iteration (b's
    # stop before the run, and its stop at the shutdown, around them)
    hooks = [(r[1], r[2]) for r in sink.records if " at iteration " in r[2]]
    at = int(hooks[-3][1].split()[-1])
    assert hooks[-3:-1] == [("/a", f"stop at iteration {at}"), ("/b", f"start at iteration {at}")]
    with trace.open() as f:
        table = [(int(r["iteration"]), float(r["/x"]), float(r["/y_a"]), float(r["/y_b"]))
                 for r in csv.DictReader(f)]
    # a follows up to the switch, b from it on: no iteration with neither, nor both
    writer = ["a" if ya == x + 1000.0 else "b" if yb == x + 1000.0 else "-"
              for _, x, ya, yb in table]
    first_b = writer.index("b")
    assert writer == ["a"] * first_b + ["b"] * (len(table) - first_b)
    assert first_b > 20 and table[first_b][0] == at


def test_a_switch_across_lanes_gives_each_worker_its_share() -> None:
    mod = "rtcf_lifecycle_components"
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY), simulated=True) as runner:
        runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
        runner.load(ComponentSpec("a", module=mod, class_name="Follower",
                                  remaps=[("y", "y_a")]))
        runner.load(ComponentSpec("b", module=mod, class_name="Follower",
                                  remaps=[("y", "y_b")], lane="side"))
        runner.run(3)
        assert runner._owner_of("/b") is not runner  # a worker process of its own
        outcomes = runner.change_states([("/b", "deactivate"), ("/a", "deactivate"),
                                         ("/b", "activate")])
        assert [(o.ok, o.label, o.end_label) for o in outcomes] == [
            (True, "deactivate", "inactive"), (True, "deactivate", "inactive"),
            (True, "activate", "active")]
        assert [runner.lifecycle_state(n) for n in ("/a", "/b")] == ["inactive", "active"]
        assert runner.shutdown() == []


def test_an_error_in_a_hook_crosses_back_with_its_reason() -> None:
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY), simulated=True) as runner:
        load_pair(runner, fail_stop=True)
        runner.run(3)
        out = runner.change_state("/follower", "deactivate")  # between runs: at once
        assert (out.ok, out.result, out.error_result, out.end_label) == (
            False, "error", "success", "unconfigured"
        )
        assert "stop() raised RuntimeError: brake stuck" in out.reason
        assert runner.lifecycle_state("/follower") == "unconfigured"
        refusal = runner.change_state("/follower", "activate")
        assert refusal.result == "refused" and "available: configure [1]" in refusal.reason
        with pytest.raises(RtcfError, match="'/ghost' is not loaded"):
            runner.change_state("/ghost", "activate")
        assert runner.shutdown() == []


def test_transitions_between_runs_reach_an_idle_worker_through_the_request_queue() -> None:
    """rt_runner's main thread waits on its request queue while the mode keeps the loop
    from running; a transition from another thread wakes it without a stop."""
    settings = RunnerSettings(frequency=FREQUENCY, mode="wait_for_trigger")
    with WorkerRunner(settings) as runner:
        load_pair(runner)
        requests = RequestQueue(runner)
        done = threading.Event()
        said: list[str] = []
        results: dict[str, Any] = {}

        def serve(req: Request) -> None:
            serve_request(req, runner, said.append, lambda p: "", lambda f: "")

        def operate() -> None:
            try:
                time.sleep(0.3)  # the main thread waits on the queue by now
                t0 = time.monotonic()
                # configured, not yet started: inactive; taken back and configured again,
                # it is not activated when the loop starts
                results["idle"] = runner.change_state("/ramp", "cleanup")
                results["idle_s"] = time.monotonic() - t0
                assert runner.change_state("/ramp", "configure").ok
                assert requests.submit("activate", None).ok  # the loop may start
                wait_until(lambda: runner.loop_running)
                results["before"] = runner.lifecycle_state("/ramp")
                results["running"] = runner.change_state("/ramp", "activate")
            finally:
                done.set()
                runner.request_stop()

        t = threading.Thread(target=operate)
        t.start()
        requests.serve_until_stopped(serve, done.is_set, lambda: runner.run(None) and None)
        t.join()
        assert runner.shutdown() == []
    assert results["idle"].ok and results["idle"].end_label == "unconfigured"
    assert results["before"] == "inactive"
    assert results["idle_s"] < 0.09  # woken at once, not at the queue's 0.1 s timeout
    assert results["running"].ok and results["running"].end_label == "active"
    assert said == []  # nothing was refused


def test_what_a_fault_policy_takes_out_is_a_lifecycle_change_the_supervisor_hears() -> None:
    from rtcf._core._faults import FailurePolicy

    heard: list[tuple[str, str, str]] = []
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY), simulated=True) as runner:
        runner.transition_listeners.append(lambda n, o: heard.append((n, o.label, o.end_label)))
        runner.load(ComponentSpec("ramp", module="rtcf_lifecycle_components", class_name="Flaky",
                                  params={"fail_at": 4},
                                  policy=FailurePolicy(on_error="deactivate")))
        runner.load(ComponentSpec("follower", module="rtcf_lifecycle_components",
                                  class_name="Follower"))
        runner.run(10)
        assert runner.lifecycle_state("/ramp") == "inactive"
        assert runner.lifecycle_state("/follower") == "inactive"
        assert runner.change_state("/follower", "activate").ok
        assert runner.shutdown() == []
    assert heard == [
        ("/ramp", "activate", "active"), ("/follower", "activate", "active"),  # the start
        ("/ramp", "deactivate", "inactive"), ("/follower", "deactivate", "inactive"),
        ("/follower", "activate", "active"),
    ]


def test_inputs_past_their_deadline_are_named_from_every_lane() -> None:
    """/diagnostics, the status line and component_info read live_status(): an input
    in another lane than main is named there too."""
    mod = "rtcf_lifecycle_components"
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY)) as runner:
        runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
        for name, lane in (("near", "main"), ("far", "other")):
            policy = FailurePolicy.from_params({"deadline/x": 0.05}, f"/{name}")
            runner.load(ComponentSpec(name, module=mod, class_name="Follower", lane=lane,
                                      policy=policy))

        def operate() -> None:
            try:
                wait_until(lambda: runner.loop_running and runner.live_status().iterations > 20)
                assert runner.live_status().past_deadline == ()  # the ramp writes /x
                assert runner.change_state("/ramp", "deactivate").ok
                wait_until(lambda: len(runner.live_status().past_deadline) == 2)
                seen.append(runner.live_status())
            finally:
                runner.request_stop()

        seen: list[Any] = []
        t = threading.Thread(target=operate)
        t.start()
        runner.run(None)
        t.join()
        status = seen[0]
        assert sorted(status.past_deadline) == ["/far.x", "/near.x"]
        assert status.deadline_misses >= 2
        assert runner.shutdown() == []


def test_a_component_loaded_unconfigured_gets_its_ports_at_its_first_configure(
    tmp_path: Path,
) -> None:
    """Loaded unconfigured (load_controller's way), a component has no ports; its first
    configure, asked for from another thread while the loop runs (a request, or
    change_state: configure_controller, a lifecycle service), is served between two runs
    as a load is: the supervisor describes the ports, and the next run's plan has them."""
    trace = tmp_path / "trace.csv"
    mod = "rtcf_lifecycle_components"
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY)) as runner:
        runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
        for name, out in (("queued", "y"), ("asked", "z")):
            runner.load(ComponentSpec(name, module=mod, class_name="Follower",
                                      remaps=[("y", out)], unconfigured=True))
        assert runner.components["/queued"]["inputs"] == []
        assert runner.components["/queued"]["configured"] is False
        assert runner.lifecycle_state("/asked") == "unconfigured"
        requests = RequestQueue(runner)
        done = threading.Event()
        results: dict[str, Any] = {}

        def serve(req: Request) -> None:
            serve_request(req, runner, print, lambda p: "", lambda f: "")

        def operate() -> None:
            try:
                wait_until(lambda: runner.loop_running)
                results["queued"] = requests.submit("configure", "/queued").outcome
                results["queued_inputs"] = list(runner.components["/queued"]["inputs"])
                wait_until(lambda: runner.loop_running)
                results["asked"] = runner.change_state("/asked", "configure")
                results["asked_inputs"] = list(runner.components["/asked"]["inputs"])
                for name in ("/queued", "/asked"):
                    assert runner.change_state(name, "activate").ok
                time.sleep(0.2)
            finally:
                done.set()
                runner.request_stop()

        t = threading.Thread(target=operate)
        t.start()
        requests.serve_until_stopped(
            serve, done.is_set, lambda: runner.run(None, trace=str(trace)) and None)
        t.join()
        assert runner.shutdown() == []
    for name in ("queued", "asked"):
        assert results[name].ok and results[name].end_label == "inactive"
        assert [p["topic"] for p in results[f"{name}_inputs"]] == ["/x"]  # described at once
    with trace.open() as f:
        rows = list(csv.DictReader(f))
    assert float(rows[-1]["/y"]) == float(rows[-1]["/x"]) + 1000.0
    assert float(rows[-1]["/z"]) == float(rows[-1]["/x"]) + 1000.0


def test_a_first_configure_the_running_loop_applies_ends_its_run_to_run_again() -> None:
    """With no request queue (a program of its own), the running loop applies the first
    configure as it applies any transition; its run then ends (CONTROL: the loop is
    to run again) and the next run describes and connects the new ports."""
    mod = "rtcf_lifecycle_components"
    with WorkerRunner(RunnerSettings(frequency=FREQUENCY)) as runner:
        runner.load(ComponentSpec("ramp", module=mod, class_name="Ramp"))
        runner.load(ComponentSpec("late", module=mod, class_name="Follower",
                                  unconfigured=True))
        outcomes: list[TransitionOutcome] = []

        def operate() -> None:
            wait_until(lambda: runner.loop_running and runner.live_status().iterations > 5)
            outcomes.append(runner.change_state("/late", "configure"))

        t = threading.Thread(target=operate)
        t.start()
        first = runner.run(2000)  # ends early, after the iteration that configured it
        t.join()
        assert outcomes[0].ok and first.iterations < 2000
        assert runner.stop_reason == CONTROL
        runner.clear_stop()
        assert runner.change_state("/late", "activate").ok
        runner.run(5)
        assert [p["topic"] for p in runner.components["/late"]["inputs"]] == ["/x"]
        assert runner.introspect()["order"] == ["/ramp", "/late"]
        assert runner.shutdown() == []
