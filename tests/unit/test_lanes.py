"""Lanes in the core: kinds, the steps of a lane, and their values in one process."""

from __future__ import annotations

import pytest

import rtcf
from rtcf._core._clock import SimClock
from rtcf._core._errors import ConfigurationError
from rtcf._core._executor import Executor, StopFlag, compile_plans
from rtcf._core._faults import FailurePolicy, WatchdogTripped
from rtcf._core._lanes import (
    LET_IN,
    LET_OUT,
    RECV,
    SEND,
    TAKE,
    UPDATE,
    Member,
    Step,
    lanes_of,
)
from rtcf._core._loop_state import LoopState
from rtcf._core._rates import Rate
from rtcf._core._runner import ComponentSpec, Runner
from rtcf._core._settings import RunnerSettings
from rtcf._core._timing import TimingWriter, local_ring
from rtcf._core._trace import Trace
from rtcf.testing import run_launch

from .._launches import let_launch


class Counter(rtcf.Component):
    def configure(self) -> None:
        self.out = self.add_output("count", int)

    def update(self) -> None:
        self.out.write(self.iteration)


class Slow(rtcf.Component):
    """Writes what it read of /count, with the iteration it ran in."""

    def configure(self) -> None:
        self.inp = self.add_input("count", int)
        self.out = self.add_output("plan", int)

    def update(self) -> None:
        v = self.inp.read()
        self.out.write(-1 if v is None else v)


class Reader(rtcf.Component):
    def configure(self) -> None:
        self.inp = self.add_input("plan", int)
        self.out = self.add_output("seen", int)
        self.iterations: list[int] = []

    def update(self) -> None:
        v = self.inp.read()
        self.iterations.append(self.inp.iteration)
        self.out.write(-2 if v is None else v)


def _run(specs: list[ComponentSpec], iterations: int, **settings: object) -> dict[str, list]:
    runner = Runner(RunnerSettings(frequency=100.0, **settings), clock=SimClock())  # type: ignore[arg-type]
    for spec in specs:
        runner.load(spec)
    rows: list[Trace] = []

    def sample() -> None:
        if not rows:
            rows.append(Trace(runner.components, runner.state, runner.visible_slots()))
        rows[0].sample()

    runner.run(iterations, on_iteration=sample)
    trace = rows[0]
    out = {t: [r[2 + k] for r in trace.rows] for k, t in enumerate(trace.topics)}
    out["iteration"] = [r[0] for r in trace.rows]
    runner.shutdown()
    return out


def test_let_lane_reads_at_release_and_shows_at_the_next_window() -> None:
    out = _run(
        [
            ComponentSpec("counter", Counter),
            ComponentSpec("slow", Slow, rate=Rate(every=4), lane="mpc"),
            ComponentSpec("reader", Reader),
        ],
        16,
    )
    # released at 0, 4, 8, 12: reads /count as iteration i - 1 left it (none at 0);
    # its result is what the others see from i + 4 to i + 7
    assert out["/plan"] == [None] * 4 + [-1] * 4 + [3] * 4 + [7] * 4
    assert out["/seen"] == [-2] * 4 + [-1] * 4 + [3] * 4 + [7] * 4
    assert out["/count"] == list(range(16))


def test_let_lane_with_a_phase() -> None:
    out = _run(
        [
            ComponentSpec("counter", Counter),
            ComponentSpec("slow", Slow, rate=Rate(every=3, phase=1), lane="mpc"),
            ComponentSpec("reader", Reader),
        ],
        11,
    )
    # released at 1, 4, 7, 10; visible from 4, 7, 10
    assert out["/plan"] == [None] * 4 + [0] * 3 + [3] * 3 + [6]


def test_let_values_differ_from_a_slow_component_in_the_main_lane() -> None:
    seq = _run(
        [
            ComponentSpec("counter", Counter),
            ComponentSpec("slow", Slow, rate=Rate(every=4)),
            ComponentSpec("reader", Reader),
        ],
        8,
    )
    # in the main lane it runs at its place in the order: this iteration's count
    assert seq["/plan"] == [0] * 4 + [4] * 4


def test_lock_step_lanes_in_one_process_give_the_sequential_values() -> None:
    plain = run_launch("rtcf_examples paper_evaluation.launch", iterations=50,
                       inputs={"/G2_R2": 1.0})
    assert plain.outputs["/R3_out2"][-1] is not None

    def with_lanes(spec: ComponentSpec) -> ComponentSpec:
        spec.lane = {"/R1": "left", "/R2": "right", "/R3": "right"}.get(spec.full_name, "")
        return spec

    from rtcf._launch._files import load_deployment

    deployment = load_deployment(["rtcf_examples", "paper_evaluation.launch"])
    specs = [with_lanes(s) for s in deployment.runner.components]
    runner = Runner(deployment.runner.settings, clock=SimClock(),
                    parameters=deployment.parameters)
    for spec in specs:
        runner.load(spec)
    assert set(runner.lanes()) == {"main", "left", "right"}
    assert runner.schedule == runner.order  # lock step: the sequential order
    runner.shutdown()


def test_a_lane_that_mixes_rates_is_an_error_naming_it() -> None:
    members = [Member("/a", "arm", 1), Member("/b", "arm", 2)]
    with pytest.raises(ConfigurationError, match="lane 'arm' mixes rates"):
        lanes_of(members, ["/a", "/b"])
    lanes = lanes_of([Member("/a", "mpc", 5, 2), Member("/b", "mpc", 5)], ["/a", "/b"])
    assert lanes["mpc"].let and lanes["mpc"].every == 5 and lanes["mpc"].phase == 2
    assert not lanes["main"].let
    with pytest.raises(ConfigurationError, match="different phases"):
        lanes_of([Member("/a", "mpc", 5, 2), Member("/b", "mpc", 5, 3)], ["/a", "/b"])


def test_the_main_lane_may_mix_rates() -> None:
    lanes = lanes_of([Member("/a", "main", 1), Member("/b", "main", 4)], ["/a", "/b"])
    assert not lanes["main"].let


def _runner(specs: list[ComponentSpec], **settings: object) -> Runner:
    runner = Runner(RunnerSettings(frequency=100.0, **settings), clock=SimClock())  # type: ignore[arg-type]
    for spec in specs:
        runner.load(spec)
    return runner


def test_steps_of_a_lock_step_lane_hand_over_where_the_sequential_run_reads() -> None:
    # Fig. 1's loop: H1 (is_first) -> F1 -> R1 -> H1; H1 and R1 in the main lane, F1 in b
    from rtcf_examples import Mimo

    def mimo(name: str, lane: str, remaps: dict[str, str], first: bool = False) -> ComponentSpec:
        return ComponentSpec(name, Mimo, remaps=remaps, lane=lane, is_first=first)

    specs = [
        mimo("H1", "", {"out1": "/h", "in1": "/r"}, first=True),
        mimo("F1", "b", {"in1": "/h", "out1": "/f"}),
        mimo("R1", "", {"in1": "/f", "out1": "/r"}),
    ]
    main = _runner(specs)
    assert main.order == ["/H1", "/F1", "/R1"]
    assert main.lane_plan() == [
        Step(UPDATE, "/H1"),
        Step(SEND, "/h"),
        Step(RECV, "/f", False, "b"),
        Step(UPDATE, "/R1"),
    ]
    main.lane = "b"  # what b's worker computes from the same facts
    main._invalidate()
    assert main.lane_plan() == [
        Step(RECV, "/h", False, "main"),
        Step(UPDATE, "/F1"),
        Step(SEND, "/f"),
    ]
    main.shutdown()


def test_a_reader_before_its_producer_takes_the_last_iterations_value() -> None:
    from rtcf_examples import Mimo

    specs = [
        ComponentSpec("A", Mimo, remaps={"in1": "/z", "out1": "/a"}, is_first=True),
        ComponentSpec("Z", Mimo, remaps={"in1": "/a", "out1": "/z"}, lane="b"),
    ]
    runner = _runner(specs)
    steps = runner.lane_plan()
    assert steps[0] == Step(RECV, "/z", True, "b")  # delayed: A runs before Z
    assert steps[0].label == "@recv /z"
    runner.shutdown()


def test_steps_of_a_let_lane_take_first_and_hand_over_last() -> None:
    runner = _runner([
        ComponentSpec("counter", Counter),
        ComponentSpec("slow", Slow, rate=Rate(every=4), lane="mpc"),
        ComponentSpec("reader", Reader),
    ])
    assert runner.lane_plan() == [
        Step(LET_IN, "/plan", False, "mpc"),
        Step(UPDATE, "/counter"),
        Step(SEND, "/count"),
        Step(UPDATE, "/reader"),
    ]
    runner.lane = "mpc"
    runner._invalidate()
    assert runner.lane_plan() == [
        Step(TAKE, "/count", True, "main"),
        Step(UPDATE, "/slow"),
        Step(LET_OUT, "/plan"),
    ]
    # a LET lane's edges do not order: /reader may come before /slow
    assert [e.ignored_by for e in runner.graph.edges] == ["logical execution time"] * 2
    runner.shutdown()


def test_lanes_need_the_absolute_wait_policy() -> None:
    runner = _runner(
        [ComponentSpec("counter", Counter), ComponentSpec("r", Reader, lane="b")],
        wait_policy="relative",
    )
    with pytest.raises(ConfigurationError, match="wait_policy 'relative' does not go with lanes"):
        runner.graph  # noqa: B018
    runner.shutdown()


def test_a_fallback_in_another_lane_is_an_error() -> None:
    runner = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    runner.load(ComponentSpec("counter", Counter, policy=FailurePolicy("deactivate", 0, "/spare")))
    runner.set_foreign([], [Member("/spare", "b")])
    with pytest.raises(ConfigurationError, match="fallback '/spare' is in lane 'b'"):
        runner.graph  # noqa: B018
    runner.shutdown()


def test_a_bad_lane_name_is_refused_at_load() -> None:
    runner = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    with pytest.raises(rtcf.ComponentError, match="not a valid lane name"):
        runner.load(ComponentSpec("counter", Counter, lane="left arm"))


def test_always_steps_run_in_every_plan_even_inactive() -> None:
    calls: list[str] = []
    updates = [lambda: calls.append("a"), lambda: calls.append("h")]
    plans = compile_plans(updates, [True, False], [(3, 0), (1, 0)], [False, True])
    assert len(plans) == 3
    assert [len(p.steps) for p in plans] == [2, 1, 1]  # 'h' always; 'a' every 3rd
    assert all(p.skipped == () for p in plans[:1])


def test_an_executor_with_a_stride_runs_the_releases_and_skips_missed_ones() -> None:
    state = LoopState(1000.0)
    ran: list[int] = []
    costs = iter([0, 9_000_000] + [0] * 100)  # the second release takes 9 ms
    clock = SimClock()

    def work() -> None:
        ran.append(state.iteration)
        clock.advance(next(costs))

    ex = Executor([work], clock, state)
    ex.stride = 4
    ex.skip_missed = True
    state.iteration = 2 - 4  # the first release is iteration 2 (its phase)
    ex.timing = TimingWriter(["w"], local_ring(1, 64))
    ex.run(20, StopFlag())
    # 2, 6 (takes 9 ms: past 10 and 14), then on the grid again at 18
    assert ran[:3] == [2, 6, 18]
    assert ex.missed == 2
    assert ex.timing.overruns == 1



def test_max_let_overruns_ends_a_let_lanes_loop_past_that_many_windows() -> None:
    state = LoopState(1000.0)
    ran: list[int] = []
    # releases at 2, 6, 10, ...: those at 6 and 18 overrun their 4 ms windows
    costs = {6: 5_000_000, 18: 5_000_000, 30: 5_000_000}
    clock = SimClock()

    def work() -> None:
        ran.append(state.iteration)
        clock.advance(costs.get(state.iteration, 0))

    ex = Executor([work], clock, state)
    ex.stride = 4
    ex.skip_missed = True
    ex.max_let_overruns = 1  # the first is counted, the second trips
    state.iteration = 2 - 4
    ex.timing = TimingWriter(["w"], local_ring(1, 64))
    with pytest.raises(WatchdogTripped) as trip:
        ex.run(40, StopFlag())
    assert (trip.value.limit, trip.value.allowed, trip.value.measured) == (
        "max_let_overruns", 1, 2)
    assert trip.value.iteration == 18  # the release whose window it overran
    assert ran == [2, 6, 14, 18]  # 10 was skipped after 6 overran
    assert "2 windows of logical execution time not finished in time, the last released " \
        "at iteration 18" in trip.value.describe()


def test_max_let_overruns_leaves_a_lock_step_loop_alone() -> None:
    state = LoopState(1000.0)
    clock = SimClock()
    ex = Executor([lambda: clock.advance(2_000_000)], clock, state)  # every one overruns
    ex.max_let_overruns = 1
    ex.timing = TimingWriter(["w"], local_ring(1, 64))
    ex.run(10, StopFlag())
    assert ex.timing.overruns == 10


def test_max_let_overruns_is_a_runner_parameter() -> None:
    assert RunnerSettings.from_params({"max_let_overruns": "3"}).max_let_overruns == 3
    with pytest.raises(ConfigurationError, match="max_let_overruns must not be negative"):
        RunnerSettings(max_let_overruns=-1)


ROS2_LAUNCH = """<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="frequency" value="1000.0"/>
  </node>
  <node pkg="rtcf" exec="rt_launcher" name="slow" args="rtcf_examples Identity">
    <param name="every" value="10"/>
    <param name="lane" value="mpc"/>
  </node>
</launch>
"""


def test_a_launchers_lane_parameter_in_both_formats(tmp_path: pytest.TempPathFactory) -> None:
    from rtcf._launch._files import load_deployment

    ros1 = tmp_path / "lanes.launch"  # type: ignore[operator]
    ros1.write_text(let_launch(lane="mpc"))
    specs = {s.name: s for s in load_deployment([str(ros1)]).runner.components}
    assert specs["slow"].lane == "mpc" and specs["src"].lane == ""
    assert "lane" not in specs["slow"].params  # read by the launcher, not a parameter
    ros2 = tmp_path / "lanes.launch.xml"  # type: ignore[operator]
    ros2.write_text(ROS2_LAUNCH)
    (spec,) = load_deployment([str(ros2)]).runner.components
    assert spec.lane == "mpc"


def test_a_bad_lane_in_a_launch_file_names_file_and_line(tmp_path: pytest.TempPathFactory) -> None:
    from rtcf._core._errors import LaunchError
    from rtcf._launch._files import load_deployment

    path = tmp_path / "bad.launch"  # type: ignore[operator]
    text = let_launch(lane="left arm")
    path.write_text(text)
    with pytest.raises(LaunchError, match="lane 'left arm' is not a valid lane name") as info:
        load_deployment([str(path)])
    # the line of its launcher's node
    line = 1 + next(i for i, t in enumerate(text.splitlines()) if '<node name="slow"' in t)
    assert info.value.file == str(path) and info.value.line == line == 10
