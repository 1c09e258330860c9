"""``rtcf launch``'s loop with a request queue: controllers loaded while it runs.

An ``rt_runner`` serves load and unload requests between two runs of its worker
(:mod:`._requests`): a request ends the run after its iteration, the main thread
serves it, and the loop runs on. ``rtcf launch`` under a middleware does the same
with :func:`run_serving`, so that its controller manager's ``load_controller`` and
``unload_controller`` (a spawner, ``ros2 control``) are served as under
``rt_runner``. Its run is then several runs of the worker; what it reports is one
(:func:`merged`): the iterations counted over all of them (``--duration`` is the
whole run's), the histograms merged, the faults, safe stops and deadline events of
each. The loop pauses while a request is served (the load, the graph resolved again,
the run's segments opened); the deadlines resume on a new grid after it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .._core._errors import RtcfError
from .._core._executor import ABORT, STOP
from .._core._loop import RunResult
from .._core._runner import ComponentSpec
from .._core._timing import TimingAggregate
from ._requests import Request, RequestQueue, serve_request

if TYPE_CHECKING:
    from ._recording import RecordSink
    from ._supervisor import WorkerRunner


def run_serving(
    runner: WorkerRunner, iterations: int | None, *, say: Callable[[str], None],
    trace: str | None = None, record: RecordSink | None = None,
) -> RunResult:
    """Run ``iterations`` (None: until stopped) and serve the requests queued meanwhile
    between runs (loads of a controller's :class:`ComponentSpec`, unloads, lifecycle
    hand-overs); the runs' results merged into one."""
    requests = RequestQueue(runner)
    results: list[RunResult] = []
    finished = False

    def load(payload: Any) -> str:
        if not isinstance(payload, ComponentSpec):
            raise RtcfError("rtcf launch loads controllers (load_controller) only")
        full = runner.load(payload)
        say(f"loaded {full} ({payload.module}.{payload.class_name})")
        return ""

    def serve(req: Request) -> None:
        serve_request(req, runner, say, load, lambda full: "")

    def run() -> None:
        nonlocal finished
        left = None if iterations is None else iterations - sum(r.iterations for r in results)
        if left is not None and left <= 0:
            finished = True
            return
        result = runner.run(left, trace=trace, record=record)
        results.append(result)
        finished = result.stopped_by != "stop" or runner.stop_reason in (STOP, ABORT)

    try:
        requests.serve_until_stopped(serve, lambda: finished, run)
    finally:
        requests.refuse_pending("the loop has ended")
        runner.requests = None
        runner.wake_idle = None
    if not results:
        raise RtcfError("the loop did not run")
    return merged(results)


def merged(results: list[RunResult]) -> RunResult:
    """Several runs of one loop as one: counts summed, histograms merged, the last
    run's order and totals (those over the runner's life: deadlines, limits)."""
    if len(results) == 1:
        return results[0]
    last = results[-1]
    aggregate = _merged_aggregate([r.aggregate for r in results if r.aggregate is not None])
    iterations = sum(r.iterations for r in results)
    overruns = sum(r.timing.overruns for r in results)
    timing = aggregate.summary(iterations, overruns) if aggregate is not None else last.timing
    inputs: dict[str, dict[str, int]] = {}
    for r in results:
        for topic, counts in r.inputs.items():
            into = inputs.setdefault(topic, {})
            for key, n in counts.items():
                into[key] = into.get(key, 0) + n
    return RunResult(
        iterations=iterations, stopped_by=last.stopped_by, timing=timing, order=last.order,
        log_records_dropped=max(r.log_records_dropped for r in results),
        simulated=last.simulated,
        realtime=next((r.realtime for r in results if r.realtime is not None), None),
        aggregate=aggregate,
        faults=[f for r in results for f in r.faults],
        safe_stops=[s for r in results for s in r.safe_stops],
        lanes=last.lanes, inputs=inputs, deadlines=last.deadlines,
        deadline_events=[e for r in results for e in r.deadline_events],
        command_limits=last.command_limits,
    )


def _merged_aggregate(aggregates: list[TimingAggregate]) -> TimingAggregate | None:
    if not aggregates:
        return None
    out = TimingAggregate()
    for a in aggregates:
        out.jitter.merge(a.jitter)
        out.calc.merge(a.calc)
        for name, hist in a.components.items():
            out.components.setdefault(name, out._new()).merge(hist)
        for phase, hist in a.phases.items():
            out._phase(phase).merge(hist)
        out.rows += a.rows
        out.overruns += a.overruns
        out.dropped += a.dropped
        out.last_iteration = a.last_iteration
    return out
