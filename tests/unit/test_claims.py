"""Claimed commands: several writers of one topic, one active at a time (rtcf._core._claims)."""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import Component, ComponentSpec, FlowStatus, Runner, RunnerSettings, SimClock
from rtcf._core import _lifecycle as lc
from rtcf._core._errors import ConfigurationError, GraphError
from rtcf._core._graph import GraphNode, PortInfo, build_graph


class Commander(Component):
    """Writes ``base + iteration`` to the claimed topic ``cmd``."""

    base = 0.0
    claim = True

    def configure(self) -> None:
        self.out = self.add_output("cmd", float, claim=self.claim)

    def update(self) -> None:
        self.out.write(self.base + self.iteration)


class Teleop(Commander):
    base = 1000.0


class Plain(Commander):
    claim = False


class Hardware(Component):
    """Reads ``cmd``: (iteration, status, value) every iteration."""

    def configure(self) -> None:
        self.inp = self.add_input("cmd", float)
        self.seen: list[tuple[int, FlowStatus, Any]] = []

    def update(self) -> None:
        self.seen.append((self.iteration, self.inp.status, self.inp.read()))


def rig(teleop_autostart: bool = False) -> tuple[Runner, Hardware]:
    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    # the reader loads first: its order must still come after both claimants
    hw = r.load(ComponentSpec("hw", Hardware))
    r.load(ComponentSpec("jtc", Commander))
    r.load(ComponentSpec("teleop", Teleop, autostart=teleop_autostart))
    assert isinstance(hw, Hardware)
    return r, hw


def test_claimants_share_the_topic_and_run_before_its_reader() -> None:
    r, hw = rig()
    assert r.graph.order.index("/hw") == 2  # after /jtc and /teleop
    r.run(3)
    assert r.lifecycle_state("/teleop") == "inactive"
    assert [v for _, _, v in hw.seen] == [0.0, 1.0, 2.0]


def test_a_switch_moves_the_claim_in_one_iteration() -> None:
    r, hw = rig()
    outcomes: list[lc.TransitionOutcome] = []

    def switch() -> None:  # after iteration 2: deactivate first, then activate
        if r.state.iteration == 2:
            outcomes.append(r.change_state("/jtc", "deactivate"))
            outcomes.append(r.change_state("/teleop", "activate"))

    r.run(6, on_iteration=switch)
    assert [o.ok for o in outcomes] == [True, True]
    # every iteration a value from exactly one writer, written this iteration
    assert hw.seen == [
        (0, FlowStatus.NEW_DATA, 0.0),
        (1, FlowStatus.NEW_DATA, 1.0),
        (2, FlowStatus.NEW_DATA, 2.0),
        (3, FlowStatus.NEW_DATA, 1003.0),
        (4, FlowStatus.NEW_DATA, 1004.0),
        (5, FlowStatus.NEW_DATA, 1005.0),
    ]


def test_with_no_claimant_active_the_last_value_stays() -> None:
    r, hw = rig()

    def off() -> None:
        if r.state.iteration == 1:
            assert r.change_state("/jtc", "deactivate").ok

    r.run(4, on_iteration=off)
    assert hw.seen[2:] == [(2, FlowStatus.OLD_DATA, 1.0), (3, FlowStatus.OLD_DATA, 1.0)]


def test_activating_a_claimant_while_another_holds_the_topic_is_refused() -> None:
    r, hw = rig()
    r.run(1)
    outcome = r.change_state("/teleop", "activate")
    assert outcome.result == lc.REFUSED and not outcome.ok
    assert "Command topic '/cmd' is already claimed by the active component '/jtc'" in (
        outcome.reason
    )
    assert r.lifecycle_state("/teleop") == "inactive" and r.lifecycle_state("/jtc") == "active"
    r.run(1)
    assert hw.seen[-1] == (1, FlowStatus.NEW_DATA, 1.0)  # /jtc still writes alone


def test_two_claimants_starting_active_is_a_configuration_error() -> None:
    r, _ = rig(teleop_autostart=True)
    with pytest.raises(ConfigurationError, match=r"'/jtc' and '/teleop' both claim .*'/cmd'.*"
                       r"--inactive"):
        r.run(1)


def test_a_plain_output_beside_claimed_ones_is_refused() -> None:
    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    r.load(ComponentSpec("hw", Hardware))
    r.load(ComponentSpec("jtc", Commander))
    r.load(ComponentSpec("raw", Plain))
    with pytest.raises(GraphError, match=r"plain output\(s\) /raw.cmd .*claim=True"):
        r.run(1)


def test_claimants_in_two_lanes_are_refused() -> None:
    def node(name: str, lane: str, out: bool) -> GraphNode:
        port = PortInfo(name, "p", "/cmd", float, claimed=out)
        return GraphNode(name, inputs=[] if out else [port], outputs=[port] if out else [],
                         lane=lane)

    nodes = [node("/a", "main", True), node("/b", "fast", True), node("/hw", "main", False)]
    with pytest.raises(GraphError, match=r"must run in one lane"):
        build_graph(nodes)
    nodes[1].lane = "main"
    graph = build_graph(nodes)
    assert graph.order == ["/a", "/b", "/hw"] and len(graph.edges) == 2


def test_a_switch_that_would_leave_two_claimants_active_is_refused() -> None:
    from rtcf._ros2._controller_manager import _claim_conflict

    states = {"jtc": "active", "teleop": "inactive", "other": "inactive", "jsb": "active"}
    claims = {"jtc": ["/cmd"], "teleop": ["/cmd"], "other": ["/cmd"], "jsb": []}
    assert _claim_conflict(["teleop"], [], states, claims) == (
        "Unable to activate controller 'teleop' since the command interface '/cmd' is "
        "currently claimed by another controller ('jtc').")
    assert _claim_conflict(["teleop"], ["jtc"], states, claims) == ""
    assert _claim_conflict(["teleop", "other"], ["jtc"], states, claims) == (
        "Unable to activate controller 'other' since the command interface '/cmd' will be "
        "used by another controller that is being activated ('teleop').")
    assert _claim_conflict(["jtc"], ["jtc"], states, claims) == ""  # a restart keeps it


def test_a_launch_file_starts_one_claimant_inactive_with_autostart_false(tmp_path) -> None:
    from rtcf.testing import run_launch

    here = "tests.unit.test_claims"
    launch = tmp_path / "claims.launch"
    nodes = (f'<node name="hw" pkg="rtcf" type="rt_launcher" args="{here} Hardware"/>'
             f'<node name="jtc" pkg="rtcf" type="rt_launcher" args="{here} Commander"/>'
             f'<node name="teleop" pkg="rtcf" type="rt_launcher" args="{here} Teleop">'
             '<param name="autostart" value="{}"/></node>')
    runner = ('<node name="rt_runner" pkg="rtcf" type="rt_runner">'
              '<param name="frequency" value="100"/></node>')
    launch.write_text(f"<launch>{runner}{nodes.format('false')}</launch>")
    trace = run_launch(str(launch), 3)
    assert trace.outputs["/cmd"] == [0.0, 1.0, 2.0]  # the jtc's; the teleop waits
    launch.write_text(f"<launch>{runner}{nodes.format('true')}</launch>")
    with pytest.raises(ConfigurationError, match="/teleop"):
        run_launch(str(launch), 3)
