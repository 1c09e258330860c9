"""Components are managed (lifecycle) nodes: the lifecycle_msgs services and events.

A separate rclpy process (this test) drives a component through its node's real
services, as ``ros2 lifecycle`` or a lifecycle manager would, and watches the
component's mapped output topic stop and resume. Both ways of running a component
are covered: ``rtcf launch --middleware ros2`` (the node lives in the supervisor) and
rt_runner with rt_launchers (the launcher's node forwards to its runner).
"""

import pytest
from lifecycle_msgs.msg import State, Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetAvailableStates, GetAvailableTransitions, GetState
from rclpy.lifecycle import LifecycleNode
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Float64

from rtcf._core import _lifecycle

from .._launches import launch_xml, launcher_xml, runner_xml
from .._proc import end_after_each_test, wait_for
from .conftest import start_rtcf
from .test_nodes import STARTED, end, launcher, runner
from .test_parameters import call
from .test_topics import spin_until, stop, wait_running

pytestmark = pytest.mark.integration


_end_all = end_after_each_test(STARTED, end)

# /lc/src -> /ros/lc_src -> /lc/relay -> /ros/lc_out
LAUNCH = launch_xml(
    '<group ns="lc">'
    + launcher_xml("src", "rtcf_examples Mimo", {"out1": "/ros/lc_src"})
    + launcher_xml("relay", "rtcf_examples Mimo", {"in1": "/ros/lc_src", "out1": "/ros/lc_out"})
    + "\n</group>",
    runner_xml(100.0, ros_mapping_whitelist="/ros/.*"),
)


class Watch:
    """Counts messages on a topic and keeps the transition events of a node."""

    def __init__(self, node, topic, component):
        self.messages = 0
        self.events = []
        node.create_subscription(Float64, topic, self._message, 100)
        # transient local, as the face publishes them: the events of an activation that
        # happened before discovery matched the two sides still arrive
        node.create_subscription(
            TransitionEvent, f"{component}/transition_event", self.events.append,
            QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )

    def _message(self, msg):
        self.messages += 1

    def quiet_for(self, node, seconds):
        """True if no message came in ``seconds`` (after letting in-flight ones land)."""
        spin_until(node, lambda: False, timeout=0.3)
        self.messages = 0
        spin_until(node, lambda: False, timeout=seconds)
        return self.messages == 0

    def flowing(self, node):
        self.messages = 0
        return spin_until(node, lambda: self.messages >= 5)


def get_state(node, component):
    return call(node, GetState, f"{component}/get_state", GetState.Request()).current_state


def change(node, component, label="", id_=0):
    req = ChangeState.Request(transition=Transition(id=id_, label=label))
    return call(node, ChangeState, f"{component}/change_state", req, timeout=30).success


def transitions(node, component, service="get_available_transitions"):
    res = call(node, GetAvailableTransitions, f"{component}/{service}",
               GetAvailableTransitions.Request())
    return [(d.transition.id, d.transition.label, d.start_state.id, d.goal_state.id)
            for d in res.available_transitions]


def events(watch, node, n):
    assert spin_until(node, lambda: len(watch.events) >= n), watch.events
    return [(e.transition.id, e.start_state.label, e.goal_state.label) for e in watch.events]


def round_trip(node, component, watch):
    """deactivate: the output stops; activate (by id): it resumes; and what the
    services and the events say meanwhile."""
    assert spin_until(node, lambda: get_state(node, component).id == State.PRIMARY_STATE_ACTIVE)
    assert watch.flowing(node), "no output before the transition"
    before = len(watch.events)
    assert change(node, component, "deactivate")
    assert get_state(node, component).label == "inactive"
    assert events(watch, node, before + 2)[before:] == [
        (4, "active", "deactivating"), (40, "deactivating", "inactive"),
    ]
    assert watch.quiet_for(node, 1.0), f"{watch.messages} messages while inactive"
    assert [t[:2] for t in transitions(node, component)] == [
        (2, "cleanup"), (3, "activate"), (6, "shutdown"),
    ]
    assert not change(node, component, "deactivate")  # not from inactive: refused
    assert change(node, component, id_=Transition.TRANSITION_ACTIVATE)  # by id
    assert watch.flowing(node), "the output did not resume"
    assert get_state(node, component).label == "active"
    assert events(watch, node, before + 4)[before + 2 :] == [
        (3, "inactive", "activating"), (30, "activating", "active"),
    ]


def test_lifecycle_round_trip_in_rtcf_launch(ros_node, tmp_path):
    path = tmp_path / "lc.launch"
    path.write_text(LAUNCH)
    watch = Watch(ros_node, "/ros/lc_out", "/lc/relay")
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    try:
        wait_running(proc)
        round_trip(ros_node, "/lc/relay", watch)
        # the standard tools find it: ros2 lifecycle looks for <node>/get_state
        services = dict(ros_node.get_service_names_and_types_by_node("relay", "/lc"))
        assert services["/lc/relay/get_state"] == ["lifecycle_msgs/srv/GetState"]
        assert services["/lc/relay/change_state"] == ["lifecycle_msgs/srv/ChangeState"]
        # cleanup, configure again, activate: the hooks run, the output flows again
        for label in ("deactivate", "cleanup", "configure", "activate"):
            assert change(ros_node, "/lc/relay", label), label
        assert watch.flowing(ros_node)
        # shutdown: finalized, nothing more to do, and the output stays quiet
        assert change(ros_node, "/lc/relay", "shutdown")
        assert get_state(ros_node, "/lc/relay").label == "finalized"
        assert transitions(ros_node, "/lc/relay") == []
        assert watch.quiet_for(ros_node, 1.0)
    finally:
        _, err = stop(proc)
    assert "[/lc/relay]: lifecycle: deactivate: active -> inactive" in err


def test_the_state_machine_is_rcls(ros_node, tmp_path):
    """Same states, same transitions per state, same graph as a real rclpy LifecycleNode."""
    path = tmp_path / "lc.launch"
    path.write_text(LAUNCH)
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    reference = LifecycleNode("rtcf_reference", context=ros_node.context)
    try:
        wait_running(proc)
        machine = reference._state_machine
        res = call(ros_node, GetAvailableStates, "/lc/src/get_available_states",
                   GetAvailableStates.Request())
        assert [(s.id, s.label) for s in res.available_states] == list(machine.available_states)
        assert transitions(ros_node, "/lc/src", "get_transition_graph") == [
            (t[0], t[1], t[2], t[4]) for t in machine.transition_graph
        ]
        for state in (1, 2, 3, 4):
            ours = [(d.transition, d.label, d.start, d.goal)
                    for d in _lifecycle.available_transitions(state)]
            assert ours == [t for t in _reference_transitions(machine, state)], state
    finally:
        reference.destroy_node()
        stop(proc)


def _reference_transitions(machine, state):
    """rcl's transitions from ``state`` (its graph's requests that start there)."""
    return [(t[0], t[1], t[2], t[4]) for t in machine.transition_graph
            if t[2] == state and t[0] < 10]


def test_lifecycle_round_trip_through_a_launchers_node(ros_node):
    r = runner("lc_runner")
    watch = Watch(ros_node, "/ros/lcl_out", "/lcl_b")
    try:
        wait_for(r, "ready")
        a = launcher("/lc_runner", "lcl_a", "Mimo", "out1:=/lcl_mid")
        b = launcher("/lc_runner", "lcl_b", "Mimo", "in1:=/lcl_mid", "out1:=/ros/lcl_out")
        wait_for(a, "loaded into")
        wait_for(b, "loaded into")
        # the runner activated it when the loop started again: the launcher saw the change
        assert events(watch, ros_node, 2)[-2:] == [
            (3, "inactive", "activating"), (30, "activating", "active"),
        ]
        watch.events.clear()
        round_trip(ros_node, "/lcl_b", watch)
        assert len(watch.events) == 4  # no double events from the launcher's polling
        end(a, b)
    finally:
        end(r)
    assert r.returncode == 0
