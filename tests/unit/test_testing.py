"""rtcf.testing: runs of N iterations on a simulated clock, for users' own tests."""

from __future__ import annotations

import doctest
import logging
import math
import re
from pathlib import Path
from typing import ClassVar

import pytest

import rtcf
import rtcf.testing
from rtcf.testing import SimClock, Trace, run_components, run_launch
from rtcf_examples import FirstOrderPlant, PaperExample, Sine

DOCS = Path(__file__).resolve().parents[2] / "docs" / "testing.md"
EXAMPLES = Path(__file__).resolve().parents[2] / "src" / "rtcf_examples" / "launch"


class Gain(rtcf.Component):
    def configure(self) -> None:
        self.inp = self.add_input("u", float)
        self.out = self.add_output("y", float)
        self.k = self.params.get("~k", 2.0)

    def update(self) -> None:
        value = self.inp.read()
        if value is not None:
            self.out.write(self.k * value)


class PController(rtcf.Component):
    """u = kp (r - y), with y from the plant's previous iteration (is_first)."""

    def configure(self) -> None:
        self.r = self.add_input("r", float)
        self.y = self.add_input("y", float)
        self.u = self.add_output("u", float)
        self.kp = float(self.params.get("~kp", 1.0))

    def update(self) -> None:
        self.u.write(self.kp * ((self.r.read() or 0.0) - (self.y.read() or 0.0)))


class Fails(rtcf.Component):
    hooks: ClassVar[list[str]] = []

    def configure(self) -> None:
        self.out = self.add_output("x", float)

    def update(self) -> None:
        if self.iteration == 2:
            raise ValueError("sensor unplugged")
        self.out.write(1.0)

    def safe_stop(self) -> None:
        Fails.hooks.append("safe_stop")

    def stop(self) -> None:
        Fails.hooks.append("stop")

    def cleanup(self) -> None:
        Fails.hooks.append("cleanup")


class BadConfig(rtcf.Component):
    def configure(self) -> None:
        raise KeyError("no such sensor")


def test_a_first_order_plant_follows_the_closed_form() -> None:
    spec = rtcf.ComponentSpec(
        "plant", FirstOrderPlant, params={"gain": 2.0, "time_constant": 0.1}
    )
    trace = run_components([spec], iterations=50, frequency=100.0, inputs={"/u": 1.0})
    alpha = 0.01 / 0.1  # explicit Euler: y[n] = y[n-1] + alpha (2 u - y[n-1])
    expected = [2.0 * (1.0 - (1.0 - alpha) ** (n + 1)) for n in range(50)]
    assert trace.outputs["/y"] == pytest.approx(expected, rel=1e-12)
    assert trace.outputs["/minus_y"][-1] == -trace.last("/y")
    assert trace.iterations == list(range(50))
    assert trace.times[:3] == [0.0, 0.01, 0.02]


def test_a_p_controller_closes_the_loop_on_the_plant_as_the_closed_form_says() -> None:
    a, g, kp, r = 0.01 / 0.1, 2.0, 1.5, 0.8
    trace = run_components(
        [
            rtcf.ComponentSpec("p", PController, params={"kp": kp}, is_first=True),
            rtcf.ComponentSpec("plant", FirstOrderPlant,
                               params={"gain": g, "time_constant": 0.1}),
        ],
        iterations=40,
        frequency=100.0,
        inputs={"/r": r},
    )
    assert trace.result is not None and trace.result.order == ["/p", "/plant"]
    # u[n] = kp (r - y[n-1]), y[n] = y[n-1] + a (g u[n] - y[n-1]), y[-1] = 0:
    # y[n] = y_inf (1 - c^(n+1)) with c = 1 - a (1 + g kp), y_inf = g kp r / (1 + g kp)
    c, y_inf = 1.0 - a * (1.0 + g * kp), g * kp * r / (1.0 + g * kp)
    ys = [y_inf * (1.0 - c ** (n + 1)) for n in range(40)]
    assert trace.outputs["/y"] == pytest.approx(ys, rel=1e-12, abs=1e-15)
    assert trace.outputs["/u"] == pytest.approx(
        [kp * (r - y) for y in [0.0, *ys[:-1]]], rel=1e-12, abs=1e-15
    )
    plant = trace.components["/plant"]
    assert isinstance(plant, FirstOrderPlant) and plant.y == trace.last("/y")


def test_inputs_land_in_their_iteration_as_constant_sequence_or_function() -> None:
    seq = run_components([Gain], iterations=4, inputs={"/u": [1.0, 2.0, 3.0]})
    assert seq.outputs["/y"] == [2.0, 4.0, 6.0, 6.0]  # the last value stays
    step = run_components([Gain], iterations=5, inputs={"/u": (0.0, 0.0, 0.0, 1.0)})
    assert step.outputs["/y"] == [0.0, 0.0, 0.0, 2.0, 2.0]
    fn = run_components(
        [Gain], iterations=3, frequency=10.0, inputs={"/u": lambda i, t: i + 10 * t}
    )
    assert fn.outputs["/y"] == pytest.approx([0.0, 4.0, 8.0])
    params = run_components(
        [rtcf.ComponentSpec("g", Gain, params={"k": 3.0})], iterations=1, inputs={"/u": 1.0}
    )
    assert params.outputs["/y"] == [3.0]
    assert isinstance(params.components["/g"], Gain)


def test_an_output_holds_none_until_its_first_write() -> None:
    trace = run_components([Gain], iterations=3, inputs={"/u": lambda i, t: None if i < 2 else 1.0})
    assert trace.outputs["/y"] == [None, None, 2.0]


def test_names_namespaces_remaps_and_global_parameters_apply() -> None:
    trace = run_components(
        [
            rtcf.ComponentSpec("g", Gain, namespace="/arm", remaps={"y": "/cmd"},
                               params={"k": 4.0}),
            rtcf.ComponentSpec("copy", PaperExample, remaps=[("in_port", "/cmd"),
                                                             ("out_port", "echo")]),
        ],
        iterations=2,
        inputs={"/arm/u": [1.0, 2.0]},
        parameters={"/test_param": 7.5},
    )
    assert sorted(trace.outputs) == ["/cmd", "/echo"]
    assert trace.outputs["/echo"] == [4.0, 8.0]  # the copy runs after the gain
    copy = trace.components["/copy"]
    assert isinstance(copy, PaperExample) and copy.param == 7.5


def test_frequency_and_settings() -> None:
    assert run_components([Sine], iterations=2).times == [0.0, 0.001]  # 1 kHz by default
    slow = rtcf.RunnerSettings(frequency=4.0, wait_policy="relative")
    assert run_components([Sine], iterations=2, settings=slow).times == [0.0, 0.25]
    assert run_components([Sine], 2, frequency=2.0, settings=slow).times == [0.0, 0.5]
    trigger = rtcf.RunnerSettings(mode="wait_for_trigger")
    assert run_components([Sine], iterations=3, settings=trigger).iterations == [0, 1, 2]
    assert run_components([Sine], iterations=0).outputs == {"/out": []}
    with pytest.raises(ValueError, match="iterations must be 0 or more"):
        run_components([Sine], iterations=-1)


def test_two_runs_are_identical() -> None:
    def once() -> Trace:
        return run_components(
            [
                rtcf.ComponentSpec("sine", Sine, remaps=[("out", "/u")],
                                   params={"frequency_hz": 3.0}),
                rtcf.ComponentSpec("plant", FirstOrderPlant),
            ],
            iterations=200,
            frequency=500.0,
        )

    a, b = once(), once()
    assert a.outputs == b.outputs and a.times == b.times and a.iterations == b.iterations
    assert len(a.outputs["/y"]) == 200 and len(set(a.outputs["/y"])) > 100
    assert a.outputs["/u"][10] == pytest.approx(math.sin(2 * math.pi * 3.0 * 10 / 500.0))


def test_a_component_that_raises_is_named_with_its_iteration() -> None:
    Fails.hooks.clear()
    with pytest.raises(rtcf.ComponentError, match=r"component '/Fails': update\(\) raised "
                       r"ValueError: sensor unplugged at iteration 2") as info:
        run_components([Fails], iterations=5)
    assert info.value.component == "/Fails"
    assert Fails.hooks == ["safe_stop", "stop", "cleanup"]


def test_a_component_whose_configure_raises_is_named() -> None:
    with pytest.raises(rtcf.ComponentError, match=r"component '/sensor': configure\(\) raised "
                       r"KeyError") as info:
        run_components([rtcf.ComponentSpec("sensor", BadConfig)], iterations=1)
    assert info.value.component == "/sensor"


def test_components_are_classes_or_specs() -> None:
    with pytest.raises(TypeError, match="give the class Gain, or a ComponentSpec, not an "
                       "instance"):
        run_components([Gain()], iterations=1)
    with pytest.raises(TypeError, match=r"neither an rtcf\.Component class nor a ComponentSpec"):
        run_components([int], iterations=1)  # type: ignore[list-item]


def test_inputs_must_be_topics_nothing_produces_and_something_reads() -> None:
    with pytest.raises(rtcf.ConfigurationError, match="'/x' is produced by /Fails"):
        run_components([Fails], iterations=1, inputs={"/x": 1.0})
    with pytest.raises(rtcf.ConfigurationError, match="no component reads /nowhere; the "
                       "inputs you can feed: /u"):
        run_components([Gain], iterations=1, inputs={"/nowhere": 1.0})
    with pytest.raises(rtcf.ConfigurationError, match="needs at least one value"):
        run_components([Gain], iterations=1, inputs={"/u": []})


def test_a_topic_two_outputs_write_is_traced_once_and_warned_about() -> None:
    trace = run_components(
        [rtcf.ComponentSpec("a", Sine), rtcf.ComponentSpec("b", Sine)], iterations=3
    )
    assert len(trace.outputs["/out"]) == 3
    assert any("'/out' is written by 2 outputs" in w for w in trace.warnings)


def test_component_logs_reach_python_logging(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="rtcf"):
        run_components([PaperExample], iterations=1, parameters={"/test_param": 3.0})
    assert [(r.name, r.getMessage()) for r in caplog.records] == [
        ("rtcf.PaperExample", "Fetched param with value 3.0")
    ]


def test_run_launch_runs_the_papers_listing_2() -> None:
    trace = run_launch("rtcf_examples paper_example.launch", iterations=5,
                       inputs={"/ros/in": [1.0, 2.0, 3.0, 4.0, 5.0]})
    # example1 (is_first) copies /ros/in to /tmp; example2 copies /tmp to /ros/out in
    # the same iteration, as the order says
    assert trace.outputs["/tmp"] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert trace.outputs["/ros/out"] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(trace.components) == ["/example1", "/example2"]
    assert trace.times[1] == pytest.approx(0.001)  # the file's 1 kHz


@pytest.mark.parametrize("name", ["sum_test.launch", "sum_test.launch.xml"])
def test_run_launch_sum_test_outputs_three_times_the_input(name: str) -> None:
    inputs = [1.0, -2.0, 0.5, 10.0]
    trace = run_launch(["rtcf_examples", name], iterations=4, inputs={"/rtcf/ros/in": inputs})
    assert trace.outputs["/rtcf/ros/out"] == [3.0 * x for x in inputs]
    assert trace.outputs["/rtcf/sum1"] == [2.0 * x for x in inputs]
    assert sorted(trace.components) == ["/rtcf/sum1", "/rtcf/sum2"]
    assert trace.times[1] == pytest.approx(0.01)  # the file's 100 Hz


def test_run_launch_takes_a_path_and_gives_the_same_as_the_package_form() -> None:
    by_path = run_launch(str(EXAMPLES / "sum_test.launch"), 3, inputs={"/rtcf/ros/in": 2.0})
    by_package = run_launch("rtcf_examples sum_test.launch", 3, inputs={"/rtcf/ros/in": 2.0})
    assert by_path.outputs == by_package.outputs
    assert by_path.last("/rtcf/ros/out") == 6.0


def test_run_launch_passes_args_to_the_file() -> None:
    trace = run_launch(
        "rtcf_examples sine_cascade.launch", iterations=60, args={"frequency": 100.0, "gain": 2.0}
    )
    assert trace.times[:2] == [0.0, 0.01]
    # reference: 2 sin(2 pi 5 t); controller: e = setpoint - y (y one iteration late);
    # plant: y += (period / 0.05) (gain e - y)
    y, ys = 0.0, []
    for n in range(60):
        e = 2.0 * math.sin(2 * math.pi * 5.0 * n * 0.01) - y
        y += 0.2 * (2.0 * e - y)
        ys.append(y)
    assert trace.outputs["/demo/y"] == pytest.approx(ys, rel=1e-9, abs=1e-12)
    default = run_launch("rtcf_examples sine_cascade.launch", iterations=2)
    assert default.times[1] == pytest.approx(0.001)


def test_run_launch_takes_ros2_xml_and_a_duration() -> None:
    trace = run_launch(["rtcf_examples", "paper_evaluation.launch.xml"], duration=0.01)
    assert len(trace.iterations) == 20  # 0.01 s at the file's 2 kHz
    assert trace.times[1] == pytest.approx(0.0005)
    assert trace.result is not None and trace.result.iterations == 20


def test_run_launch_errors() -> None:
    with pytest.raises(rtcf.LaunchError, match=r"has no launch file 'missing\.launch'"):
        run_launch("rtcf_examples missing.launch", iterations=1)
    with pytest.raises(rtcf.ConfigurationError, match="give either iterations or duration"):
        run_launch("rtcf_examples sum_test.launch")
    with pytest.raises(rtcf.ConfigurationError, match="give either iterations or duration"):
        run_launch("rtcf_examples sum_test.launch", 3, duration=1.0)
    with pytest.raises(rtcf.ConfigurationError, match=r"sum_test\.launch: no component reads "
                       "/ros/in"):
        run_launch("rtcf_examples sum_test.launch", 1, inputs={"/ros/in": 1.0})


def test_the_simulated_clock_is_rtcfs() -> None:
    assert SimClock is rtcf.SimClock


def test_the_docstring_examples_run() -> None:
    result = doctest.testmod(rtcf.testing, raise_on_error=True)
    assert result.attempted >= 4


def test_the_docs_example_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", DOCS.read_text(), re.S)
    assert blocks
    namespace: dict[str, object] = {}
    exec(compile("\n".join(blocks), str(DOCS), "exec"), namespace)
    tests = [v for k, v in namespace.items() if k.startswith("test_") and callable(v)]
    assert len(tests) >= 2
    for test in tests:
        test()
