"""A component loaded unconfigured (``ComponentSpec.unconfigured``, ros2_control's
``load_controller``): constructed, never configured, no ports in the graph or the
schedule until its first lifecycle ``configure``, which resolves the graph again."""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import Component, ComponentSpec, FlowStatus, Runner, RunnerSettings, SimClock
from rtcf._core._errors import ComponentError
from rtcf._core._executor import CONTROL

from .test_lifecycle import Sink, Source
from .test_runner import Recorder


class Counted(Component):
    """``y = x + gain``; counts its configures (ros2_control: opening a device here)."""

    configures = 0
    inits = 0
    fail: Any = None  # what configure returns or raises

    def __init__(self) -> None:
        super().__init__()
        type(self).inits += 1

    def configure(self) -> Any:
        type(self).configures += 1
        self.inp = self.add_input("x", float)
        self.out = self.add_output("y", float)
        self.gain = self.params.declare("gain", float(self.params.get("~offset", 0.0)))
        if isinstance(self.fail, BaseException):
            raise self.fail
        return self.fail

    def update(self) -> None:
        v = self.inp.read()
        if v is not None:
            self.out.write(v + self.gain.value)


@pytest.fixture(autouse=True)
def _reset() -> Any:
    Counted.configures = Counted.inits = 0
    Counted.fail = None
    yield


def runner() -> tuple[Runner, Source, Recorder]:
    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock(), log_sink=Sink())
    src = r.load(ComponentSpec("src", Source))
    sink = r.load(ComponentSpec("sink", Recorder))
    assert isinstance(src, Source) and isinstance(sink, Recorder)
    return r, src, sink


def test_loaded_unconfigured_it_is_never_configured_and_has_no_ports() -> None:
    r, _src, sink = runner()
    c = r.load(ComponentSpec("relay", Counted, params={"offset": 1000.0}, unconfigured=True))
    assert (Counted.inits, Counted.configures) == (1, 0)
    assert r.lifecycle_state("relay") == "unconfigured"
    assert c.inputs == {} and c.outputs == {}
    described = r.describe_component("relay")
    assert described["inputs"] == [] and described["outputs"] == []
    assert described["configured"] is False and described["lifecycle"] == "unconfigured"
    assert described["parameters"] == {"offset": 1000.0}  # in the tree at load
    node = next(n for n in r.graph_nodes() if n.name == "/relay")
    assert node.inputs == [] and node.outputs == []
    assert all("/relay" not in (e.producer.component, e.consumer.component)
               for e in r.graph.edges)
    assert "/relay" in r.schedule  # as a component cleaned up is: scheduled, not active
    r.run(3)  # the loop runs without it: never started, nothing reaches the sink
    assert Counted.configures == 0 and r.lifecycle_state("relay") == "unconfigured"
    assert sink.seen[-1][1] == FlowStatus.NO_DATA
    # a tunable is not there yet (declared by configure)
    assert r.describe_component("relay")["tunables"] == []


def test_its_first_configure_declares_the_ports_and_the_plan_is_resolved_again() -> None:
    r, src, sink = runner()
    r.load(ComponentSpec("relay", Counted, params={"offset": 1000.0}, unconfigured=True))
    r.run(2)
    assert r.change_state("relay", "configure").ok
    assert Counted.configures == 1 and r.lifecycle_state("relay") == "inactive"
    assert [n for n in r.order] == ["/src", "/relay", "/sink"]  # its ports order it now
    node = next(n for n in r.graph_nodes() if n.name == "/relay")
    assert [p.topic for p in node.inputs] == ["/x"] and [p.topic for p in node.outputs] == ["/y"]
    assert r.change_state("relay", "activate").ok
    r.run(2)
    assert sink.seen[-1] == (3, FlowStatus.NEW_DATA, 1003.0)
    assert [i for i, _ in src.ran] == [0, 1, 2, 3]
    # from here on it is an ordinary configured component: cleanup, configure again
    for t in ("deactivate", "cleanup", "configure", "activate"):
        assert r.change_state("relay", t).ok, t
    assert Counted.configures == 2
    r.run(1)
    assert sink.seen[-1] == (4, FlowStatus.NEW_DATA, 1004.0)


def test_a_first_configure_while_the_loop_runs_ends_the_run_to_rewire() -> None:
    """Applied between two iterations (a worker's update record): the run ends with
    CONTROL after the iteration (a control request waits; the loop runs on after it),
    and the next run has the new plan."""
    r, _src, sink = runner()
    r.load(ComponentSpec("relay", Counted, unconfigured=True))
    outcomes = []

    def hook() -> None:
        if r.state.iteration == 1:
            outcomes.append(r.change_state("relay", "configure"))

    result = r.run(10, on_iteration=hook)
    assert [o.ok for o in outcomes] == [True] and result.iterations == 2
    assert r.stop_flag.cell[0] == CONTROL
    assert r.change_state("relay", "activate").ok
    r.run(1)
    assert sink.seen[-1] == (2, FlowStatus.NEW_DATA, 2.0)


@pytest.mark.parametrize("fail", [False, RuntimeError("no device")])
def test_a_first_configure_that_fails_forgets_its_ports_and_may_be_tried_again(fail: Any) -> None:
    r, _src, sink = runner()
    c = r.load(ComponentSpec("relay", Counted, unconfigured=True))
    Counted.fail = fail
    out = r.change_state("relay", "configure")
    assert not out.ok and out.end_label == "unconfigured"
    assert ("returned False" if fail is False else "RuntimeError: no device") in out.reason
    assert c.inputs == {} and c.outputs == {}
    assert next(n for n in r.graph_nodes() if n.name == "/relay").inputs == []
    Counted.fail = None
    assert r.change_state("relay", "configure").ok and set(c.inputs) == {"x"}
    assert r.change_state("relay", "activate").ok
    r.run(1)
    assert sink.seen[-1] == (0, FlowStatus.NEW_DATA, 0.0)


def test_what_is_checked_at_an_unconfigured_load() -> None:
    """The class is imported and the name, rate and lane are checked at load; what
    configure reads is checked at configure."""
    r, _, _ = runner()
    with pytest.raises(ComponentError, match="no_such_module"):
        r.load(ComponentSpec("a", module="no_such_module", class_name="X", unconfigured=True))
    with pytest.raises(ComponentError, match="already loaded"):
        r.load(ComponentSpec("src", Counted, unconfigured=True))
    assert Counted.configures == 0 and "/a" not in r.components


def test_an_unconfigured_component_is_torn_down_without_hooks() -> None:
    r, _, _ = runner()
    r.load(ComponentSpec("relay", Counted, unconfigured=True))
    r.unload("relay")
    assert Counted.configures == 0 and "/relay" not in r.components
    assert r.shutdown() == []


def test_on_hardware_its_interfaces_are_bound_at_its_first_configure() -> None:
    """A controller of a robot description's hardware, loaded by name as ros2_control's
    load_controller does: no interfaces claimed or bound until configured."""
    from .test_hardware_loop import ARM, Arm, state
    from .test_hardware_loop import runner as hardware_runner

    r = hardware_runner()
    arm = r.load(ComponentSpec("arm", cls=Arm, unconfigured=True))
    assert r.describe_component("/arm")["interfaces"] == ([], [])
    assert r.schedule == ["@hardware.read", "/arm", "@hardware.write"]
    r.run(2)
    assert state(r, "joint3/position") == 0.0 and not hasattr(arm, "seen")
    assert r.change_state("/arm", "configure").ok
    assert r.describe_component("/arm")["interfaces"] == (ARM, ARM)
    assert r.change_state("/arm", "activate").ok
    assert r.hardware is not None and r.hardware.claimed_interfaces("/arm") == ARM
    r.run(3)
    assert state(r, "joint3/position") == pytest.approx(0.02)  # the last command is read next
    assert arm.seen == [FlowStatus.NEW_DATA] * 3
