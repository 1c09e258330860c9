"""Components at several rates in one loop, on a simulated clock: deterministic."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import rtcf
from rtcf import ComponentSpec, FlowStatus
from rtcf._core._executor import compile_plans, hyperperiod
from rtcf._core._rates import Rate, spread
from rtcf._core._timing import FIXED_COLUMNS as F
from rtcf.testing import run_components, run_launch


class Counter(rtcf.Component):
    """Writes the iteration it runs in."""

    def configure(self) -> None:
        self.out = self.add_output("count", float)
        self.ran: list[int] = []

    def update(self) -> None:
        self.ran.append(self.iteration)
        self.out.write(float(self.iteration))


class Slow(rtcf.Component):
    """Copies the count to ``held`` (run at a lower rate)."""

    def configure(self) -> None:
        self.inp = self.add_input("count", float)
        self.out = self.add_output("held", float)
        self.ran: list[int] = []

    def update(self) -> None:
        self.ran.append(self.iteration)
        self.out.write(self.inp.read())


class Reader(rtcf.Component):
    """Reads ``held`` every iteration: value, the iteration it was written in, status."""

    def configure(self) -> None:
        self.inp = self.add_input("held", float)
        self.seen: list[tuple[int, Any, int, FlowStatus]] = []

    def update(self) -> None:
        status = self.inp.status
        value = self.inp.read()
        self.seen.append((self.iteration, value, self.inp.iteration, status))


def _specs(**slow: Any) -> list[ComponentSpec]:
    return [
        ComponentSpec("counter", Counter),
        ComponentSpec("slow", Slow, rate=Rate(**slow)),
        ComponentSpec("reader", Reader),
    ]


def test_a_slow_component_runs_at_its_place_and_readers_see_which_iteration() -> None:
    trace = run_components(_specs(every=4, phase=1), iterations=10)
    slow = trace.components["/slow"]
    assert slow.ran == [1, 5, 9]
    assert trace.components["/counter"].ran == list(range(10))
    seen = trace.components["/reader"].seen
    # at its place in the order: in iteration 1 the reader sees the value of 1
    assert seen[0] == (0, None, -1, FlowStatus.NO_DATA)
    assert seen[1] == (1, 1.0, 1, FlowStatus.NEW_DATA)
    assert seen[2] == (2, 1.0, 1, FlowStatus.OLD_DATA)
    assert seen[4] == (4, 1.0, 1, FlowStatus.OLD_DATA)
    assert seen[5] == (5, 5.0, 5, FlowStatus.NEW_DATA)
    assert trace.outputs["/held"] == [None, 1.0, 1.0, 1.0, 1.0, 5.0, 5.0, 5.0, 5.0, 9.0]


def test_a_rate_in_hz_is_a_divider_of_the_runners_frequency() -> None:
    trace = run_components(_specs(rate=250.0, phase=0), iterations=9, frequency=1000.0)
    assert trace.components["/slow"].ran == [0, 4, 8]


def test_a_rate_that_does_not_divide_is_an_error_naming_both_and_the_nearest() -> None:
    with pytest.raises(rtcf.ComponentError) as info:
        run_components(_specs(rate=300.0), iterations=1, frequency=1000.0)
    assert str(info.value) == (
        "component '/slow': rate 300 Hz does not divide the runner's frequency 1000 Hz; "
        "the nearest rates that do are 333.333 Hz (every:=3) or 250 Hz (every:=4)"
    )
    with pytest.raises(rtcf.ComponentError, match="phase 4 must be below every=4"):
        run_components(_specs(every=4, phase=4), iterations=1)


def test_traces_are_identical_run_after_run() -> None:
    a = run_components(_specs(every=3), iterations=30)
    b = run_components(_specs(every=3), iterations=30)
    assert a.outputs == b.outputs and a.components["/reader"].seen == b.components[
        "/reader"
    ].seen


def test_the_runner_spreads_slow_components_over_the_phases() -> None:
    names = ["a", "b", "c", "fast"]
    rates = spread(names, [(2, None), (2, None), (4, None), (1, None)], [5.0, 4.0, 3.0, 1.0])
    assert rates == [(2, 0), (2, 1), (4, 1), (1, 0)]
    # the worst iteration carries one slow component, not two
    loads = [sum(c for (e, p), c in zip(rates, [5, 4, 3, 1], strict=True) if (i - p) % e == 0)
             for i in range(4)]
    assert max(loads) == 8 and loads == [6, 8, 6, 5]


def test_a_fixed_phase_is_kept_and_others_avoid_it() -> None:
    assert spread(["x", "y"], [(2, 0), (2, None)], [10.0, 10.0]) == [(2, 0), (2, 1)]


def test_one_plan_per_phase_selected_by_the_iteration() -> None:
    calls: list[str] = []
    updates = [lambda: calls.append("a"), lambda: calls.append("b")]
    plans = compile_plans(updates, [True, True], [(1, 0), (3, 2)])
    assert len(plans) == hyperperiod([(1, 0), (3, 2)]) == 3
    assert [len(p.steps) for p in plans] == [1, 1, 2]
    assert [p.skipped for p in plans] == [(F + 1,), (F + 1,), ()]


def test_deactivating_a_slow_component_takes_it_out_of_every_phase() -> None:
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    for spec in _specs(every=2, phase=0):
        runner.load(spec)
    runner.run(4)
    assert runner.components["/slow"].ran == [0, 2]
    assert runner.change_state("/slow", "deactivate").ok
    runner.run(4)
    assert runner.components["/slow"].ran == [0, 2]
    assert runner.change_state("/slow", "activate").ok
    runner.run(4)
    assert runner.components["/slow"].ran == [0, 2, 8, 10]
    runner.shutdown()


def test_rate_parameters_from_a_launcher() -> None:
    assert Rate.from_params({"rate": "100", "phase": 2, "cost_us": 30}, "/c") == Rate(
        100.0, 0, 2, 30.0
    )
    with pytest.raises(rtcf.ConfigurationError, match="give rate or every, not both"):
        Rate.from_params({"rate": 100.0, "every": 2}, "/c")
    with pytest.raises(rtcf.ConfigurationError, match=r"every is 2\.5, which is not a whole"):
        Rate.from_params({"every": 2.5}, "/c")


def test_a_controllers_update_rate_is_its_rate() -> None:
    """ros2_control's per-controller ``update_rate``: its rate when no ``rate`` is given;
    0 is the loop's; both given, they must agree."""
    assert Rate.from_params({"update_rate": 100}, "/c") == Rate(100.0)
    assert Rate.from_params({"update_rate": 0}, "/c") == Rate()
    assert Rate.from_params({"rate": 100.0, "update_rate": 100}, "/c") == Rate(100.0)
    with pytest.raises(rtcf.ConfigurationError) as info:
        Rate.from_params({"rate": 100.0, "update_rate": 50}, "/arm/jtc")
    assert info.value.message == (
        "component '/arm/jtc': rate 100 Hz and update_rate 50 Hz differ; give one of them "
        "(update_rate is ros2_control's name of rate)")
    with pytest.raises(rtcf.ConfigurationError, match="update_rate -1 Hz must not be negative"):
        Rate.from_params({"update_rate": -1}, "/c")
    with pytest.raises(rtcf.ConfigurationError, match="give update_rate or every, not both"):
        Rate.from_params({"update_rate": 100, "every": 2}, "/c")
    with pytest.raises(rtcf.ConfigurationError) as info:
        Rate.from_params({"update_rate": 300}, "/c").divider(1000.0, "/c")
    assert info.value.message.startswith(
        "component '/c': update_rate 300 Hz does not divide the runner's frequency 1000 Hz;")


def test_update_rate_from_a_ros2_controllers_yaml_section(tmp_path: Path) -> None:
    (tmp_path / "controllers.yaml").write_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 1000\n"
        "ramp:\n  ros__parameters:\n    update_rate: 250\n")
    launch = tmp_path / "rates.launch.xml"
    launch.write_text("""<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="frequency" value="1000.0"/>
  </node>
  <node pkg="rtcf" exec="rt_launcher" name="ramp" args="rtcf_examples Ramp">
    <param from="controllers.yaml"/>
  </node>
</launch>
""")
    trace = run_launch(str(launch), 9)
    ran = trace.ran["/ramp"]
    assert len(ran) == 3 and ran[2] - ran[1] == ran[1] - ran[0] == 4


class Integrator(rtcf.Component):
    """Integrates 1.0 over its own period: after n runs, n * period."""

    def configure(self) -> None:
        self.out = self.add_output("integral", float)
        self.total = 0.0

    def update(self) -> None:
        self.total += self.period
        self.out.write(self.total)


def test_a_slow_components_period_and_frequency_are_its_own() -> None:
    spec = ComponentSpec("i", Integrator, rate=Rate(rate=250.0, phase=0))
    trace = run_components([spec], iterations=8, frequency=1000.0)
    comp = trace.components["/i"]
    assert comp.every == 4 and comp.frequency == 250.0 and comp.period == pytest.approx(0.004)
    # two runs (iterations 0 and 4) over 8 ms of loop time: the integral is 8 ms
    assert trace.outputs["/integral"][-1] == pytest.approx(0.008)


def test_a_slow_component_loaded_between_runs_keeps_the_loops_phases() -> None:
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=rtcf.SimClock())
    runner.load(ComponentSpec("counter", Counter))
    runner.run(3)
    runner.load(ComponentSpec("slow", Slow, rate=Rate(every=4, phase=2)))
    runner.run(8)  # iterations 3..10: the phase counts from the loop's first iteration
    assert runner.components["/slow"].ran == [6, 10]
    runner.unload("/slow")
    runner.run(2)
    assert runner.components["/counter"].ran == list(range(13))
    runner.shutdown()


def test_timing_reports_each_phase_and_each_component_where_it_ran() -> None:
    # simulated cost: every update costs 1 us of simulated time
    clock = rtcf.SimClock(cost_ns=lambda n: 1000)
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=100.0), clock=clock)
    for spec in _specs(every=2, phase=1):
        runner.load(spec)
    result = runner.run(10)
    agg = result.aggregate
    assert agg is not None
    assert agg.components["/slow"].count == 5 and agg.components["/reader"].count == 10
    assert sorted(agg.phases) == [0, 1]
    assert agg.phases[0].count == agg.phases[1].count == 5
    # the phase the slow component runs in costs one update more
    assert agg.phases[1].max - agg.phases[0].max == 1000
    runner.shutdown()


def test_a_slow_components_tunable_applies_at_its_next_run() -> None:
    from rtcf._launch._files import load_deployment

    deployment = load_deployment(["rtcf_examples", "cascade.launch"])
    runner = rtcf.Runner(
        deployment.runner.settings, clock=rtcf.SimClock(), parameters=deployment.parameters
    )
    for spec in deployment.runner.components:
        runner.load(spec)
    seen: list[float] = []
    out = runner.components["/cascade/position_controller"].command
    runner.run(6, on_iteration=lambda: seen.append(out._slot.value))
    assert seen[5] != 0.0  # kp 20 on a step to 1: saturated at the limit
    assert runner.set_parameter("/cascade/position_controller", "kp", 0.0) == 0.0
    runner.run(4, on_iteration=lambda: seen.append(out._slot.value))
    # iterations 6 and 7 keep the value of 5; the run in 9 (phase 1) applies kp = 0
    assert seen[6] == seen[7] == seen[8] == seen[5] and seen[9] == 0.0
    assert runner.describe_component("/cascade/position_controller")["every"] == 4
    runner.shutdown()


def test_the_rates_table_has_a_lane_column_and_costs_the_longest_lane() -> None:
    from rtcf._core._rates import plan_table

    lines = plan_table(
        ["/a", "/b", "/c", "/mpc"],
        [(1, 0), (2, 0), (1, 0), (4, 1)],
        [20.0, 30.0, 45.0, 4000.0],
        1000.0,
        ["main", "main", "right", "mpc"],
    )
    rows = {line.split()[0]: line.split() for line in lines if line.startswith("  /")}
    assert rows["/c"][-1] == "right"
    assert rows["/mpc"][-2:] == ["mpc", "(LET)"]
    assert rows["/a"][-1] == "main"
    # phase 0: main 20 + 30 = 50 against right's 45; phases 1-3: 45 (right) over 20
    assert lines[-1].endswith("worst first: 50 in 2 phases (0, 2); 45 in 2 phases (1, 3)")
    assert "LET lanes apart" in lines[-1]
    # without lanes (or with the main lane only) the table is as before: costs add up
    plain = plan_table(["/a", "/b"], [(1, 0), (2, 0)], [20.0, 30.0], 1000.0, ["main", "main"])
    assert "lane" not in plain[2]
    assert plain[-1].endswith("(cost_us), worst first: 50 in 1 phase (0); 20 in 1 phase (1)")


def test_the_rates_table_has_rows_for_components_only() -> None:
    from rtcf._core._rates import plan_table

    # the runner's own LET step (``@let``) runs every iteration in the schedule, but it
    # is not a component of the launch file: no row, and nothing of it in the costs
    lines = plan_table(
        ["@let", "/mpc", "/a"], [(1, 0), (4, 1), (1, 0)], [0.0, 4000.0, 20.0], 1000.0,
        ["main", "mpc", "main"],
    )
    assert [line.split()[0] for line in lines[3:-1]] == ["/mpc", "/a"]
    assert not any("@let" in line for line in lines)
    assert lines[-1].endswith("worst first: 20 in 4 phases (0, 1, 2, 3)")
