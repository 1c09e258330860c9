"""The runner: loading, modes, lifecycle hooks, data flow and logging, on a SimClock."""

from __future__ import annotations

import math
from typing import Any

import pytest

import rtcf_examples
from rtcf import (
    Component,
    ComponentError,
    ComponentSpec,
    ConfigurationError,
    FlowStatus,
    ParameterStore,
    Runner,
    RunnerSettings,
    SimClock,
)
from rtcf._core._errors import Location
from rtcf._core._log import LogRecord

# -- helpers -------------------------------------------------------------------------


class Sink:
    """A log sink that keeps (level, logger, text, iteration)."""

    def __init__(self) -> None:
        self.records: list[tuple[int, str, str, int]] = []

    def __call__(self, rec: LogRecord) -> None:
        self.records.append((rec.level, rec.logger, rec.format(), rec.iteration))


def make_runner(frequency: float = 100.0, **kw: Any) -> Runner:
    settings = kw.pop("settings", None) or RunnerSettings(frequency=frequency)
    kw.setdefault("log_sink", Sink())
    kw.setdefault("clock", SimClock())
    return Runner(settings, **kw)


class Counter(Component):
    """Writes ``offset + iteration`` to ``x``."""

    def configure(self) -> None:
        self.out = self.add_output("x", float)
        self.offset = self.params.get("~offset", 0.0)
        self.times: list[tuple[int, int]] = []

    def update(self) -> None:
        self.times.append((self.iteration, self.time_ns))
        self.out.write(self.offset + self.iteration)


class Relay(Component):
    """Writes ``x + offset`` to ``y``."""

    def configure(self) -> None:
        self.inp = self.add_input("x", float)
        self.out = self.add_output("y", float)
        self.offset = self.params.get("~offset", 1000.0)

    def update(self) -> None:
        v = self.inp.read()
        if v is not None:
            self.out.write(v + self.offset)


class Recorder(Component):
    """Records (iteration, status before reading, value) of input ``y``."""

    def configure(self) -> None:
        self.inp = self.add_input("y", float)
        self.seen: list[tuple[int, FlowStatus, Any]] = []

    def update(self) -> None:
        status = self.inp.status
        self.seen.append((self.iteration, status, self.inp.read()))


EVENTS: list[str] = []


class Hooks(Component):
    """Records every hook call into EVENTS."""

    def configure(self) -> None:
        EVENTS.append(f"configure {self.full_name}")
        if self.params.get("~out", ""):
            self.add_output(self.params.get("~out"), float)
        if self.params.get("~in", ""):
            self.add_input(self.params.get("~in"), float)

    def start(self) -> None:
        EVENTS.append(f"start {self.full_name}")

    def update(self) -> None:
        EVENTS.append(f"update {self.full_name} {self.iteration}")

    def stop(self) -> None:
        EVENTS.append(f"stop {self.full_name}")

    def cleanup(self) -> None:
        EVENTS.append(f"cleanup {self.full_name}")


@pytest.fixture(autouse=True)
def _clear_events() -> None:
    EVENTS.clear()


# -- loading -------------------------------------------------------------------------


def test_load_by_class() -> None:
    r = make_runner()
    c = r.load(ComponentSpec("count", Counter, namespace="ns"))
    assert isinstance(c, Counter)
    assert (c.name, c.namespace, c.full_name) == ("count", "/ns", "/ns/count")
    assert r.components == {"/ns/count": c}
    assert c.outputs["x"].topic == "/ns/x"
    assert c.iteration == -1


def test_load_by_module_and_class_name_from_examples() -> None:
    store = ParameterStore({"/test_param": 4.5})
    r = make_runner(parameters=store)
    c = r.load(ComponentSpec("paper", module="rtcf_examples", class_name="PaperExample"))
    assert type(c) is rtcf_examples.PaperExample
    assert c.param == 4.5
    assert set(c.inputs) == {"in_port"} and set(c.outputs) == {"out_port"}
    assert r.log_sink.records == [(20, "/paper", "Fetched param with value 4.5", -1)]


def test_load_unknown_class_names_component_and_alternatives() -> None:
    r = make_runner()
    with pytest.raises(ComponentError) as info:
        r.load(ComponentSpec("x", module="rtcf_examples", class_name="Nope"))
    assert info.value.component == "/x"
    assert "'/x'" in str(info.value) and "'Nope'" in str(info.value)
    assert "PaperExample" in str(info.value)
    assert r.components == {}


def test_load_missing_module() -> None:
    with pytest.raises(ComponentError, match="module 'no_such_mod_rtcf' is not found"):
        make_runner().load(ComponentSpec("x", module="no_such_mod_rtcf", class_name="C"))


def test_load_a_class_that_is_not_a_component() -> None:
    with pytest.raises(ComponentError, match=r"rtcf_examples\._components\.math is not a subclass"):
        make_runner().load(ComponentSpec("x", module="rtcf_examples._components",
                                         class_name="math"))


def test_private_params_from_spec() -> None:
    store = ParameterStore({"/ns/public_param": 3.25})
    r = make_runner(parameters=store)
    c = r.load(ComponentSpec(
        "ph",
        module="rtcf_examples",
        class_name="ParameterHandling",
        namespace="/ns",
        params={"int_param": 7, "double_param": 1.5},
    ))
    assert (c.int_param, c.double_param, c.size, c.public_param) == (7, 1.5, 1, 3.25)
    assert store.get("/ns/ph/int_param") == 7
    assert store.get("/ns/ph/double_param") == 1.5


def test_remaps_choose_the_topic() -> None:
    r = make_runner()
    c = r.load(ComponentSpec("id", rtcf_examples.Identity, namespace="/ns",
                             remaps=[("in_port", "/sensor"), ("out_port", "~filtered")]))
    assert c.inputs["in_port"].topic == "/sensor"
    assert c.outputs["out_port"].topic == "/ns/id/filtered"


@pytest.mark.parametrize("name", ["a/b", "1a", ""])
def test_bad_component_names(name: str) -> None:
    with pytest.raises(ComponentError):
        make_runner().load(ComponentSpec(name, Counter))


def test_loading_the_same_name_twice() -> None:
    r = make_runner()
    r.load(ComponentSpec("c", Counter))
    with pytest.raises(ComponentError, match="'/c': is already loaded"):
        r.load(ComponentSpec("c", Counter))


def test_bad_topics_ignore_regex() -> None:
    with pytest.raises(ComponentError, match="topics_ignore_for_graph '\\(' is not a valid"):
        make_runner().load(ComponentSpec("c", Counter, topics_ignore_for_graph="("))


def test_unload_unknown_lists_loaded() -> None:
    r = make_runner()
    r.load(ComponentSpec("c", Counter))
    with pytest.raises(ComponentError, match=r"'/nope' is not loaded \(loaded: /c\)"):
        r.unload("nope")


# -- modes ---------------------------------------------------------------------------


def test_wait_for_components() -> None:
    r = make_runner(settings=RunnerSettings(
        mode="wait_for_components", num_components_expected=2, frequency=10))
    r.load(ComponentSpec("a", Counter))
    assert not r.ready
    with pytest.raises(ConfigurationError, match="1 of the 2 expected"):
        r.run(1)
    r.load(ComponentSpec("b", Recorder))
    assert r.ready
    assert r.run(1).iterations == 1
    with pytest.raises(ComponentError) as info:
        r.load(ComponentSpec("c", Recorder))
    assert "one more than the 2 components" in str(info.value)
    assert info.value.component == "/c"
    assert set(r.components) == {"/a", "/b"}


def test_no_wait_runs_with_one_component_but_not_none() -> None:
    r = make_runner()
    with pytest.raises(ConfigurationError, match="no component is loaded"):
        r.run(1)
    r.load(ComponentSpec("a", Counter))
    assert r.run(2).iterations == 2


def test_wait_for_trigger_needs_activate() -> None:
    r = make_runner(settings=RunnerSettings(mode="wait_for_trigger", frequency=10))
    c = r.load(ComponentSpec("a", Counter))
    with pytest.raises(ConfigurationError, match="has not been activated"):
        r.run(1)
    assert c.times == []
    r.activate()
    assert r.run(1).iterations == 1
    r.deactivate()
    with pytest.raises(ConfigurationError, match="has not been activated"):
        r.run(1)


# -- hooks ---------------------------------------------------------------------------


def test_hooks_in_order() -> None:
    r = make_runner()
    # /z produces /t and /a consumes it: order /z, /a despite the names
    r.load(ComponentSpec("z", Hooks, params={"out": "t"}))
    assert EVENTS == ["configure /z"]
    r.load(ComponentSpec("a", Hooks, params={"in": "t"}))
    assert EVENTS == ["configure /z", "configure /a"]
    r.run(2)
    assert EVENTS[2:] == [
        "start /z", "start /a",
        "update /z 0", "update /a 0",
        "update /z 1", "update /a 1",
    ]
    EVENTS.clear()
    r.run(1)  # no second start
    assert EVENTS == ["update /z 2", "update /a 2"]
    EVENTS.clear()
    assert r.shutdown() == []
    assert EVENTS == ["stop /a", "cleanup /a", "stop /z", "cleanup /z"]
    assert r.components == {}


def test_unload_stops_and_cleans_up_one() -> None:
    r = make_runner()
    r.load(ComponentSpec("a", Hooks))
    r.load(ComponentSpec("b", Hooks))
    r.run(1)
    EVENTS.clear()
    r.unload("a")
    assert EVENTS == ["stop /a", "cleanup /a"]
    EVENTS.clear()
    r.run(1)
    assert EVENTS == ["update /b 1"]


def test_never_started_component_is_only_cleaned_up() -> None:
    r = make_runner()
    r.load(ComponentSpec("a", Hooks))
    r.load(ComponentSpec("b", Hooks))
    r.shutdown()
    assert EVENTS == ["configure /a", "configure /b", "cleanup /b", "cleanup /a"]


def test_new_component_is_started_before_its_first_update() -> None:
    r = make_runner()
    r.load(ComponentSpec("b", Hooks))
    r.run(1)
    r.load(ComponentSpec("a", Hooks))
    EVENTS.clear()
    r.run(1)
    assert EVENTS == ["start /a", "update /a 1", "update /b 1"]


class FailConfigure(Component):
    def configure(self) -> bool:
        return False


class RaiseConfigure(Component):
    def configure(self) -> None:
        raise ValueError("bad gain")


def test_configure_returning_false() -> None:
    r = make_runner()
    with pytest.raises(ComponentError) as info:
        r.load(ComponentSpec("f", FailConfigure, location=Location("x.launch", 12)))
    assert str(info.value) == "x.launch:12: component '/f': configure() returned False"
    assert info.value.component == "/f"
    assert r.components == {}


def test_configure_raising() -> None:
    r = make_runner()
    with pytest.raises(ComponentError) as info:
        r.load(ComponentSpec("f", RaiseConfigure, namespace="/ns"))
    assert str(info.value) == "component '/ns/f': configure() raised ValueError: bad gain"
    assert isinstance(info.value.__cause__, ValueError)
    assert r.components == {}


def test_configure_missing_parameter_names_it() -> None:
    class NeedsParam(Component):
        def configure(self) -> None:
            self.params.get("~gain")

    with pytest.raises(ComponentError) as info:
        make_runner().load(ComponentSpec("n", NeedsParam))
    assert "configure() failed" in str(info.value) and "'/n/gain'" in str(info.value)


class FailStart(Component):
    def start(self) -> bool:
        return False

    def update(self) -> None:
        EVENTS.append("update")


class RaiseStart(Component):
    def start(self) -> None:
        raise RuntimeError("no device")

    def update(self) -> None:
        EVENTS.append("update")


@pytest.mark.parametrize(
    ("cls", "text"),
    [(FailStart, "start() returned False"), (RaiseStart, "start() raised RuntimeError: no device")],
)
def test_start_failure(cls: type[Component], text: str) -> None:
    r = make_runner()
    r.load(ComponentSpec("s", cls))
    with pytest.raises(ComponentError) as info:
        r.run(3)
    assert str(info.value) == f"component '/s': {text}"
    assert info.value.component == "/s"
    assert EVENTS == []


class Explode(Component):
    def configure(self) -> None:
        self.inp = self.add_input("x", float)

    def update(self) -> None:
        if self.iteration == 3:
            raise ZeroDivisionError("division by zero")


def test_update_raising_names_component_and_iteration_and_stops() -> None:
    r = make_runner()  # 100 Hz
    counter = r.load(ComponentSpec("a", Counter))
    r.load(ComponentSpec("b", Explode, namespace="/ns", remaps={"x": "/x"}))
    with pytest.raises(ComponentError) as info:
        r.run(10)
    msg = str(info.value)
    assert msg.startswith("component '/ns/b': update() raised ZeroDivisionError: division by zero")
    assert "at iteration 3 (t=0.030000 s)" in msg
    assert "the loop was stopped" in msg
    assert info.value.component == "/ns/b"
    assert isinstance(info.value.__cause__, ZeroDivisionError)
    assert [i for i, _ in counter.times] == [0, 1, 2, 3]
    assert r.state.running is False


def test_hook_errors_at_shutdown_are_collected() -> None:
    class BadStop(Component):
        def update(self) -> None:
            pass

        def stop(self) -> None:
            raise OSError("stuck")

        def cleanup(self) -> None:
            EVENTS.append(f"cleanup {self.full_name}")

    r = make_runner()
    r.load(ComponentSpec("a", BadStop))
    r.load(ComponentSpec("b", BadStop))
    r.run(1)
    errors = r.shutdown()
    assert [str(e) for e in errors] == [
        "component '/b': stop() raised OSError: stuck",
        "component '/a': stop() raised OSError: stuck",
    ]
    assert EVENTS == ["cleanup /b", "cleanup /a"]


# -- data flow -----------------------------------------------------------------------


def _chain(r: Runner) -> tuple[Counter, Recorder]:
    p = r.load(ComponentSpec("p", Counter))
    r.load(ComponentSpec("r", Relay))
    k = r.load(ComponentSpec("k", Recorder))
    return p, k


def test_chain_passes_data_in_the_same_iteration() -> None:
    r = make_runner()
    _, k = _chain(r)
    result = r.run(3)
    assert result.order == ["/p", "/r", "/k"]
    assert result.stopped_by == "count" and result.iterations == 3
    assert result.simulated is True
    assert k.seen == [
        (0, FlowStatus.NEW_DATA, 1000.0),
        (1, FlowStatus.NEW_DATA, 1001.0),
        (2, FlowStatus.NEW_DATA, 1002.0),
    ]


def test_unload_while_running_stops_and_next_run_reresolves() -> None:
    r = make_runner()
    p, k = _chain(r)
    relay = r.components["/r"]
    relay_calls: list[int] = []
    relay.update = lambda: (relay_calls.append(relay.iteration), Relay.update(relay))  # type: ignore[method-assign]

    def on_iteration() -> None:
        if r.state.iteration == 2:
            r.unload("r")

    result = r.run(10, on_iteration=on_iteration)
    assert (result.iterations, result.stopped_by) == (3, "stop")
    assert relay_calls == [0, 1, 2]  # never called after it was unloaded
    assert [v for _, _, v in k.seen] == [1000.0, 1001.0, 1002.0]

    # without the relay nothing orders /k after /p: plain name order
    result = r.run(2)
    assert result.order == ["/k", "/p"]
    assert k.seen[3:] == [(3, FlowStatus.NO_DATA, None), (4, FlowStatus.NO_DATA, None)]

    r.load(ComponentSpec("a_relay", Relay, params={"offset": 2000.0}))
    result = r.run(2)
    assert result.order == ["/p", "/a_relay", "/k"]
    assert k.seen[5:] == [(5, FlowStatus.NEW_DATA, 2005.0), (6, FlowStatus.NEW_DATA, 2006.0)]
    # the time grid goes on across the re-resolving
    assert p.times == [(i, i * 10_000_000) for i in range(7)]


def test_timing_after_reresolving_reports_the_new_samples() -> None:
    r = make_runner(clock=SimClock(cost_ns=lambda n: 10))
    _chain(r)
    r.run(3)
    r.unload("r")
    result = r.run(2)
    # two scheduled updates: calc is two reads after t0, each costing 10 ns
    assert result.timing.samples == 2
    assert result.timing.calc_us["min"] == 0.02 and result.timing.calc_us["max"] == 0.02
    assert result.timing.jitter_us["max"] == 0.01
    assert set(result.timing.components_us) == {"/k", "/p"}


class Plant(Component):
    """y = 10 * u."""

    def configure(self) -> None:
        self.u = self.add_input("u", float)
        self.y = self.add_output("y", float)
        self.seen: list[tuple[int, Any]] = []

    def update(self) -> None:
        u = self.u.read()
        self.seen.append((self.iteration, u))
        self.y.write(10.0 * (u or 0.0))


class Controller(Component):
    """u = y + 1 (y taken as 0 before the plant first wrote)."""

    def configure(self) -> None:
        self.y = self.add_input("y", float)
        self.u = self.add_output("u", float)
        self.seen: list[tuple[int, FlowStatus, Any]] = []

    def update(self) -> None:
        status = self.y.status
        y = self.y.read()
        self.seen.append((self.iteration, status, y))
        self.u.write((y or 0.0) + 1.0)


@pytest.mark.parametrize(
    "ctrl_spec",
    [{"is_first": True}, {"topics_ignore_for_graph": "/y"}],
    ids=["is_first", "topics_ignore_for_graph"],
)
def test_ignored_edge_delivers_data_one_iteration_late(ctrl_spec: dict[str, Any]) -> None:
    r = make_runner()
    plant = r.load(ComponentSpec("a_plant", Plant))
    ctrl = r.load(ComponentSpec("z_ctrl", Controller, **ctrl_spec))
    r.run(4)
    assert r.order == ["/z_ctrl", "/a_plant"]
    ignored = [e for e in r.graph.edges if not e.orders]
    assert [(e.topic, e.ignored_by) for e in ignored] == [("/y", next(iter(ctrl_spec)))]
    # the controller sees the plant's output of the previous iteration
    assert ctrl.seen == [
        (0, FlowStatus.NO_DATA, None),
        (1, FlowStatus.NEW_DATA, 10.0),
        (2, FlowStatus.NEW_DATA, 110.0),
        (3, FlowStatus.NEW_DATA, 1110.0),
    ]
    # the plant sees the controller's output of the same iteration
    assert plant.seen == [(0, 1.0), (1, 11.0), (2, 111.0), (3, 1111.0)]


def test_cycle_without_is_first_fails_to_run() -> None:
    r = make_runner()
    r.load(ComponentSpec("a_plant", Plant))
    r.load(ComponentSpec("z_ctrl", Controller))
    with pytest.raises(Exception, match="cycle in the data flow"):
        r.run(1)


class Sometimes(Component):
    """Writes ``x`` at iterations 1, 2 and 4."""

    def configure(self) -> None:
        self.out = self.add_output("y", float)

    def update(self) -> None:
        if self.iteration in (1, 2, 4):
            self.out.write(float(self.iteration))


class Peek(Component):
    """Looks at the status of ``y`` without reading it."""

    def configure(self) -> None:
        self.inp = self.add_input("y", float)
        self.seen: list[FlowStatus] = []

    def update(self) -> None:
        self.seen.append(self.inp.status)


def test_flow_status_per_iteration() -> None:
    r = make_runner()
    r.load(ComponentSpec("a", Sometimes))
    rec = r.load(ComponentSpec("b", Recorder))
    peek = r.load(ComponentSpec("c", Peek))
    r.run(6)
    new, old, none = FlowStatus.NEW_DATA, FlowStatus.OLD_DATA, FlowStatus.NO_DATA
    assert rec.seen == [
        (0, none, None), (1, new, 1.0), (2, new, 2.0), (3, old, 2.0), (4, new, 4.0), (5, old, 4.0),
    ]
    assert peek.seen == [none, new, new, new, new, new]  # never read: the value stays new


def test_unconnected_input_is_reported_and_has_no_data() -> None:
    r = make_runner()
    rec = r.load(ComponentSpec("k", Recorder))
    r.run(2)
    assert [p.qualified_name for p in r.graph.unconnected_inputs] == ["/k.y"]
    assert not rec.inp.connected
    assert rec.seen == [(0, FlowStatus.NO_DATA, None), (1, FlowStatus.NO_DATA, None)]


# -- loop information ----------------------------------------------------------------


class Clocked(Component):
    def configure(self) -> None:
        self.seen: list[tuple[int, float, int, float, float]] = []

    def update(self) -> None:
        self.seen.append((self.iteration, self.time, self.time_ns, self.frequency, self.period))


def test_time_iteration_frequency_on_simclock() -> None:
    r = make_runner(frequency=250.0, clock=SimClock(start_ns=10**12))
    c = r.load(ComponentSpec("c", Clocked))
    assert (c.iteration, c.time, c.frequency, c.period) == (-1, 0.0, 250.0, 0.004)
    r.run(3)
    assert c.seen == [
        (0, 0.0, 0, 250.0, 0.004),
        (1, 0.004, 4_000_000, 250.0, 0.004),
        (2, 0.008, 8_000_000, 250.0, 0.004),
    ]
    assert c.iteration == 2


def test_sine_example_follows_scheduled_time() -> None:
    r = make_runner(frequency=4.0)
    sine = r.load(ComponentSpec("s", module="rtcf_examples", class_name="Sine",
                                params={"amplitude": 2.0, "frequency_hz": 1.0, "offset": 0.5}))
    rec = r.load(ComponentSpec("k", Recorder, remaps={"y": "out"}))
    r.run(4)
    assert sine.out.topic == "/out"
    values = [v for _, _, v in rec.seen]
    assert values == pytest.approx([0.5, 2.5, 0.5, -1.5], abs=1e-12)


def test_first_order_plant_example() -> None:
    class One(Component):
        def configure(self) -> None:
            self.out = self.add_output("u", float)

        def update(self) -> None:
            self.out.write(1.0)

    r = make_runner(frequency=100.0)
    r.load(ComponentSpec("one", One))
    plant = r.load(ComponentSpec("plant", rtcf_examples.FirstOrderPlant,
                                 params={"gain": 2.0, "time_constant": 0.05}))
    ys: list[float] = []
    r.run(3, on_iteration=lambda: ys.append(plant.y))
    # alpha = period / tau = 0.2: y += 0.2 * (2 - y)
    assert ys == pytest.approx([0.4, 0.72, 0.976])
    assert plant.minus_y._slot.value == pytest.approx(-0.976)


def test_run_until_stop_requested() -> None:
    r = make_runner()
    r.load(ComponentSpec("c", Counter))

    def on_iteration() -> None:
        if r.state.iteration == 4:
            r.request_stop()

    result = r.run(on_iteration=on_iteration)
    assert (result.iterations, result.stopped_by) == (5, "stop")
    # a new run is not stopped by the old request
    assert r.run(2).stopped_by == "count"


# -- logging -------------------------------------------------------------------------


def test_logging_from_update_reaches_the_sink_with_iterations() -> None:
    sink = Sink()
    r = make_runner(log_sink=sink)
    r.load(ComponentSpec("log", rtcf_examples.Logging, namespace="/ns"))
    # configure's records (debug is below the default INFO level) at iteration -1
    assert [(lvl, it) for lvl, _, _, it in sink.records] == [
        (20, -1), (30, -1), (40, -1), (50, -1)
    ]
    assert sink.records[0][2] == "Test non-RT info with number 12345"
    assert {name for _, name, _, _ in sink.records} == {"/ns/log"}
    sink.records.clear()
    result = r.run(2)
    assert [(lvl, text, it) for lvl, _, text, it in sink.records] == [
        (level, f"Test RT {word} at iteration {i}", i)
        for i in range(2)
        for level, word in ((20, "info"), (30, "warning"), (40, "error"), (50, "fatal"))
    ]
    assert result.log_records_dropped == 0


def test_full_log_ring_counts_drops() -> None:
    sink = Sink()
    r = make_runner(log_sink=sink, log_capacity=4)
    r.load(ComponentSpec("log", rtcf_examples.Logging))
    sink.records.clear()
    result = r.run(3, drain_logs_every_iteration=False)
    # iteration 0 fills the ring; iterations 1 and 2 lose all 4 of theirs
    assert result.log_records_dropped == 8
    assert [it for _, _, _, it in sink.records] == [0, 0, 0, 0]


def test_log_ring_drained_each_iteration_does_not_drop() -> None:
    sink = Sink()
    r = make_runner(log_sink=sink, log_capacity=4)
    r.load(ComponentSpec("log", rtcf_examples.Logging))
    sink.records.clear()
    result = r.run(3)
    assert result.log_records_dropped == 0
    assert [it for _, _, _, it in sink.records] == [0] * 4 + [1] * 4 + [2] * 4


# -- schedule and determinism ------------------------------------------------------------


class NoUpdate(Component):
    def configure(self) -> None:
        self.add_output("y", float)

    def start(self) -> None:
        EVENTS.append("start no-update")


def test_components_without_update_are_not_scheduled() -> None:
    r = make_runner()
    r.load(ComponentSpec("quiet", NoUpdate))
    r.load(ComponentSpec("k", Recorder))
    r.load(ComponentSpec("bare", rtcf_examples.BareMinimum))
    assert r.order == ["/bare", "/quiet", "/k"]
    assert r.schedule == ["/bare", "/k"]
    result = r.run(2)
    assert set(result.timing.components_us) == {"/bare", "/k"}
    assert EVENTS == ["start no-update"]  # still started


def _closed_loop() -> list[tuple[float, ...]]:
    r = make_runner(frequency=50.0)
    r.load(ComponentSpec("sine", rtcf_examples.Sine, params={"frequency_hz": 2.0},
                         remaps={"out": "in1"}))
    r.load(ComponentSpec("sum", rtcf_examples.Mimo, remaps={"in2": "minus_y", "out1": "u"}))
    plant = r.load(ComponentSpec("plant", rtcf_examples.FirstOrderPlant, is_first=True,
                                 params={"gain": 3.0}))
    ident = r.load(ComponentSpec("id", rtcf_examples.Identity,
                                 remaps={"in_port": "y", "out_port": "y_copy"}))
    trace: list[tuple[float, ...]] = []
    r.run(40, on_iteration=lambda: trace.append(
        (plant.y, ident.port_out._slot.value, r.components["/sum"].out1._slot.value)))
    assert r.order == ["/plant", "/id", "/sine", "/sum"]
    return trace


def test_same_setup_twice_gives_identical_values() -> None:
    a = _closed_loop()
    b = _closed_loop()
    assert len(a) == 40
    assert a == b
    assert len({v[0] for v in a}) > 30  # the values do change
    assert all(math.isfinite(x) for row in a for x in row)
    # the identity copies y of the same iteration
    assert all(y == copy for y, copy, _ in a)


def test_component_constructed_directly_has_its_own_context() -> None:
    c = rtcf_examples.Identity()
    c.configure()
    assert c.full_name == "/Identity"
    assert c.inputs["in_port"].topic == "/in_port"
    assert c.iteration == -1
    c.log.info("hello")
    assert len(c.log._ring) == 1


def test_adding_ports_after_configure_is_refused() -> None:
    class Late(Component):
        def update(self) -> None:
            self.add_input("late", float)

    r = make_runner()
    r.load(ComponentSpec("late", Late))
    with pytest.raises(ComponentError, match="add_input/add_output called after configure"):
        r.run(1)


def test_duplicate_port_and_non_class_type_are_refused() -> None:
    class Dup(Component):
        def configure(self) -> None:
            self.add_input("p", float)
            self.add_output("p", float)

    class NotAType(Component):
        def configure(self) -> None:
            self.add_input("p", "float")  # type: ignore[arg-type]

    with pytest.raises(ComponentError, match="port 'p' is declared twice"):
        make_runner().load(ComponentSpec("d", Dup))
    with pytest.raises(ComponentError, match="which is not a class"):
        make_runner().load(ComponentSpec("n", NotAType))


def test_loading_from_inside_the_loop_stops_it_and_the_next_run_includes_the_component() -> None:
    r = make_runner()
    r.load(ComponentSpec("src", Counter))
    loaded: list[Component] = []

    def load_once() -> None:
        if not loaded and r.state.iteration == 2:
            loaded.append(r.load(ComponentSpec("relay", Relay, params={"offset": 0.5})))

    first = r.run(10, on_iteration=load_once)
    assert first.stopped_by == "stop" and first.iterations == 3
    second = r.run(2)
    assert second.order == ["/src", "/relay"]  # re-resolved: the relay follows its producer
    assert second.iterations == 2
    assert loaded[0].outputs["y"]._slot.value == 4.5  # x of iteration 4, plus 0.5


def test_numpy_arrays_pass_by_reference_through_ports() -> None:
    np = pytest.importorskip("numpy")

    class ArraySource(Component):
        def configure(self) -> None:
            self.out = self.add_output("vec", np.ndarray)

        def update(self) -> None:
            self.out.write(np.full(3, float(self.iteration)))

    class ArraySink(Component):
        def configure(self) -> None:
            self.inp = self.add_input("vec", np.ndarray)
            self.seen: list[object] = []

        def update(self) -> None:
            self.seen.append(self.inp.read())

    r = make_runner()
    src = r.load(ComponentSpec("a", ArraySource))
    sink = r.load(ComponentSpec("b", ArraySink))
    r.run(3)
    assert [v.tolist() for v in sink.seen] == [[0.0] * 3, [1.0] * 3, [2.0] * 3]
    assert sink.seen[-1] is src.outputs["vec"]._slot.value  # no copy on the way
