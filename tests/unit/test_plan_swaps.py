"""A change of what the loop runs (a lifecycle transition, a fault's fallback swap)
compiles its plans where the executor builds them (Executor.set_active): the loop's
first iteration after it only takes them, and allocates no more than any other
iteration. Counted with tracemalloc (which sees the compiled path's PyMem arrays too),
on both paths."""

from __future__ import annotations

import gc
import tracemalloc
from collections.abc import Callable, Iterator
from types import ModuleType

import pytest

from rtcf import SimClock
from rtcf._core import _executor, _interpreted
from rtcf._core._executor import Executor, StopFlag, UpdateFailure
from rtcf._core._timing import FIXED_COLUMNS as F
from rtcf._core._timing import TimingWriter, local_ring

try:
    from rtcf._core import _compiled  # type: ignore[attr-defined]
except ImportError as exc:  # a failure, not a skip: CI builds it
    raise AssertionError(f"rtcf._core._compiled is not built: {exc}") from None

N = 40  # components: the compiled plans of 40 are a few kB, allocated in 3 blocks


class Component:
    def __init__(self) -> None:
        self.fail = False

    def update(self) -> None:
        if self.fail:
            raise RuntimeError("failed")


@pytest.fixture(params=[pytest.param(_compiled, id="compiled"),
                        pytest.param(_interpreted, id="Python")])
def path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[ModuleType]:
    """The executor on one path or the other, whichever RTCF_PURE_PYTHON chose."""
    m: ModuleType = request.param
    monkeypatch.setattr(_executor, "Calculation", m.Calculation)
    monkeypatch.setattr(_executor, "CompiledPlans", m.CompiledPlans)
    gc.disable()  # no collection inside a counted stretch
    try:
        yield m
    finally:
        gc.enable()


class Counted:
    """What a stretch of the loop leaves allocated: (blocks, bytes) traced from
    ``open`` to ``close`` and still alive at its end."""

    def __init__(self) -> None:
        self.counts: dict[str, tuple[int, int]] = {}
        self._name = ""

    def open(self, name: str) -> None:
        self._name = name
        tracemalloc.start()

    def close(self) -> None:
        traces = tracemalloc.take_snapshot().traces
        tracemalloc.stop()
        self.counts[self._name] = (len(traces), sum(t.size for t in traces))


def _executor_of(components: list[Component], clock: SimClock, m: ModuleType) -> Executor:
    state = m.LoopState(1000.0)  # the path's own (the compiled Calculation checks it)
    timing = TimingWriter([f"/c{k}" for k in range(len(components))],
                          local_ring(len(components), 4096))
    return Executor([c.update for c in components], clock, state, timing)


def _script(ex: Executor, steps: dict[int, Callable[[], None]]) -> Callable[[], None]:
    """An idle hook that runs steps[i] after iteration i."""

    def idle() -> None:
        step = steps.get(ex.state.iteration)
        if step is not None:
            step()

    return idle


def test_the_first_iteration_after_a_deactivation_or_activation_allocates_nothing_more(
    path: ModuleType,
) -> None:
    components = [Component() for _ in range(N)]
    ex = _executor_of(components, SimClock(), path)
    counted = Counted()
    on = [True] * N
    off = [k != 7 for k in range(N)]

    def swap(flags: list[bool], name: str) -> Callable[[], None]:
        def step() -> None:
            counted.close()
            ex.set_active(flags)  # between iterations (an idle hook, a feeder)
            counted.open(name)

        return step

    ex.idle = _script(ex, {
        299: lambda: counted.open("steady"),  # i > 256: every int allocates, in each
        300: swap(off, "after deactivate"),
        301: swap(on, "after activate"),
        302: counted.close,
    })
    assert ex.run(400, StopFlag()) == 400
    steady = counted.counts["steady"]
    assert counted.counts == {
        "steady": steady, "after deactivate": steady, "after activate": steady,
    }, path.__name__


def test_a_swap_in_a_feeder_applies_in_the_same_iteration_and_allocates_nothing_more(
    path: ModuleType,
) -> None:
    """A transition the supervisor asked for is applied by a feeder, in the timed part
    of the iteration: from there to the iteration's end, nothing more allocates."""
    components = [Component() for _ in range(N)]
    ex = _executor_of(components, SimClock(), path)
    counted = Counted()
    off = [k % 2 == 0 for k in range(N)]

    def feeder() -> None:
        i = ex.state.iteration
        if i == 300:
            counted.open("steady")
        elif i == 301:
            ex.set_active(off)
            counted.open("after deactivate")

    ex.feeders = (feeder,)
    ex.idle = _script(ex, {300: counted.close, 301: counted.close})
    assert ex.run(400, StopFlag()) == 400
    assert counted.counts["after deactivate"] == counted.counts["steady"], path.__name__
    assert ex.plans[0].skipped == tuple(F + k for k in range(1, N, 2))


def test_the_first_iteration_after_a_fallback_swap_allocates_nothing_more(
    path: ModuleType,
) -> None:
    """An update raised: the run ends; its component goes out of the schedule and its
    fallback in (as the runner's on_error: deactivate does), and the loop resumes. The
    resumed run's first iteration, from its sleep to its end, allocates what a steady
    one does."""
    components = [Component() for _ in range(N)]
    fallback = N - 1
    counted = Counted()

    class Clock(SimClock):
        armed = ""

        def sleep_until_ns(self, deadline_ns: int) -> None:
            if self.armed:
                counted.open(self.armed)
                self.armed = ""
            super().sleep_until_ns(deadline_ns)

    clock = Clock()
    ex = _executor_of(components, clock, path)
    ex.set_active([k != fallback for k in range(N)])  # the fallback stands by
    ex.idle = _script(ex, {
        298: lambda: setattr(clock, "armed", "steady"),
        299: counted.close,
        300: lambda: setattr(components[3], "fail", True),
    })
    with pytest.raises(UpdateFailure):
        ex.run(None, StopFlag())
    components[3].fail = False
    ex.set_active([k not in (3, fallback) for k in range(N)])  # taken out
    ex.set_active([k != 3 for k in range(N)])  # its fallback activated
    clock.armed = "after the fallback swap"
    ex.idle = _script(ex, {ex.state.iteration + 1: counted.close})
    assert ex.run(1, StopFlag()) == 1
    assert counted.counts["after the fallback swap"] == counted.counts["steady"], path.__name__
    assert ex.plans[0].skipped == (F + 3,)


@pytest.mark.parametrize("m", [pytest.param(_compiled, id="compiled"),
                               pytest.param(_interpreted, id="Python")])
def test_compiled_plans_keep_their_plans_and_how_wide_a_row_must_be(m: ModuleType) -> None:
    plans = ((((F, print), (F + 2, print)), (F + 1,)), (((F + 4, print),), ()))
    compiled = m.CompiledPlans(plans)
    assert compiled.plans is plans and compiled.columns == F + 5
    for bad in ((), ("not a plan",), ((((F, print),), ()), 3), ((((F,),), ()),)):
        with pytest.raises(TypeError, match="plans"):
            m.CompiledPlans(bad)
    with pytest.raises(IndexError):
        m.CompiledPlans(((((-1, print),), ()),))
