"""A running rt_runner against a thousand generated requests (hypothesis), malformed
and well-formed, to each of its services: load, unload, tune, lifecycle and the
triggers (docs/security.md).

Checked: every request is answered, in one line without a traceback; the runner stays
up; its loop runs on after the fuzz, and was stopped and started again (its
/diagnostics "loop starts") no more often than requests were accepted: a refused one
does not stop it; loads that were accepted unload cleanly; nothing is left in /dev/shm.
"""

import os
import signal
import threading

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import given
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.parameter import Parameter as PyParameter
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from .._fuzz import (
    GOOD,
    GOOD_CLASSES,
    GOOD_NAMES,
    LONG_TEXT,
    REFUSALS,
    SHORT_TEXT,
    THOUSAND,
    Tally,
)
from .._proc import rtcf_shm_names, wait_for
from .test_nodes import end, runner
from .test_topics import spin_until

pytestmark = pytest.mark.integration

RUNNER = "fuzzed"
SERVICES = ("load_component", "unload_component", "tune_component", "lifecycle_component")
FIELDS = ("module", "class", "name", "namespace", "remaps", "is_first", "launcher",
          "topics_ignore_for_graph", "log_level", "transition", "param.gain", "param.kp",
          "lane", "", "param.", "x" * 300)
VALUES = st.one_of(
    st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(allow_nan=False),
    SHORT_TEXT, LONG_TEXT,
    st.lists(st.text(max_size=12), max_size=4),
    st.lists(st.integers(-(2**63), 2**63 - 1), max_size=4),
    st.lists(st.booleans(), max_size=3), st.lists(st.floats(allow_nan=False), max_size=3),
    st.sampled_from(["rtcf_examples", "os", "Mimo", "in1:=/x", "deactivate", "activate"]),
)
# a well-formed load now and then: it must load, run, and unload again
GOOD_LOAD = st.fixed_dictionaries({
    "module": st.just("rtcf_examples"), "class": GOOD_CLASSES, "name": GOOD_NAMES,
})
# the fields are typed by nothing but their values here: a malformed one too
REFUSED_HERE = {"a malformed field": (dict(GOOD, name="e", is_first="yes"), "is_first")}
REQUEST = st.one_of(
    st.tuples(st.just("load_component"), GOOD_LOAD),
    st.tuples(st.sampled_from(SERVICES), st.dictionaries(st.sampled_from(FIELDS), VALUES,
                                                         max_size=6)),
    st.tuples(st.sampled_from(("activate_rt_loop", "deactivate_rt_loop")), st.just({})),
)


def _parameter(name, value):
    """A request field as rcl_interfaces/Parameter (what any ROS 2 client can send)."""
    if isinstance(value, list) and not value:
        value = [""]  # ROS 2 parameters cannot carry an empty list of unknown type
    if isinstance(value, list) and len({type(v) for v in value}) > 1:
        value = [str(v) for v in value]
    return Parameter(name=name, value=PyParameter("v", value=value).get_parameter_value())


@pytest.fixture(scope="module")
def fuzzed():
    """One runner for the whole fuzz; its loop runs at 100 Hz with one component."""
    import rclpy
    from rclpy.node import Node

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node(f"rtcf_fuzz_{os.getpid()}", context=context)
    proc = runner(RUNNER)
    tally = Tally(proc, f"/{RUNNER}")
    tally.node = node
    tally.infos = []
    node.create_subscription(Float64MultiArray, f"/{RUNNER}/iteration_info",
                             lambda m: tally.infos.append(int(m.data[0])), 1000)
    clients = {s: node.create_client(SetParametersAtomically, f"/{RUNNER}/{s}")
               for s in SERVICES}
    clients.update({s: node.create_client(Trigger, f"/{RUNNER}/{s}")
                    for s in ("activate_rt_loop", "deactivate_rt_loop")})
    tally.clients = clients
    node.create_subscription(DiagnosticArray, "/diagnostics", tally.seen, 100)
    try:
        wait_for(proc, "ready")
        said = []  # the runner's lines, read on: a full pipe would block it
        reader = threading.Thread(target=lambda: said.extend(iter(proc.stderr.readline, "")),
                                  daemon=True)
        reader.start()
        tally.said = said
        assert all(c.wait_for_service(timeout_sec=20) for c in clients.values())
        yield tally
    finally:
        end(proc)
        node.destroy_node()
        rclpy.shutdown(context=context)


def _spinning(state):
    """The tally's ``wait_until``: spins the test's node while it waits."""
    return lambda predicate, timeout: spin_until(state.node, predicate, timeout=timeout)


def test_refused_loads_are_answered_without_stopping_the_loop(fuzzed):
    """Each of these is refused by the service itself: the loop runs through them on its
    time grid. A load that is not refused does stop it (to import and configure)."""
    assert _call(fuzzed, "load_component", GOOD).result.successful
    before = fuzzed.loop_starts(_spinning(fuzzed))
    for what, (fields, said) in {**REFUSALS, **REFUSED_HERE}.items():
        answer = _call(fuzzed, "load_component", fields)
        assert not answer.result.successful, what
        assert said in answer.result.reason, (what, answer.result.reason)
    assert fuzzed.loop_starts(_spinning(fuzzed)) == before, "a refused load stopped the loop"
    # the count does see a real stop: a load (with none loaded, no loop runs to say it)
    assert _call(fuzzed, "load_component", dict(GOOD, name="held2")).result.successful
    assert fuzzed.loop_starts(_spinning(fuzzed)) > before
    assert _call(fuzzed, "unload_component", {"name": "held2"}).result.successful
    fuzzed.loaded.add("/held")  # kept through the fuzz: a loop runs to say its starts


def _call(state, service, fields):
    client = state.clients[service]
    if service.endswith("_rt_loop"):
        request = Trigger.Request()
    else:
        request = SetParametersAtomically.Request()
        request.parameters = [_parameter(k, v) for k, v in fields.items()]
    future = client.call_async(request)
    assert spin_until(state.node, future.done, timeout=60), (service, fields)
    return future.result()


@THOUSAND
@given(request=REQUEST)
def test_a_thousand_generated_requests_are_each_answered(fuzzed, request):
    service, fields = request
    if fuzzed.first is None:
        fuzzed.first = fuzzed.loop_starts(_spinning(fuzzed))
    answer = _call(fuzzed, service, fields)
    assert answer is not None
    fuzzed.answered += 1
    assert fuzzed.proc.poll() is None, "the runner ended"
    if service.endswith("_rt_loop") or answer.result.successful:
        fuzzed.accepted += 1  # may stop the loop and start it again
    if service == "load_component":
        fuzzed.load_answered(f"/{fields.get('name')}", answer.result.successful,
                             answer.result.reason, one_line_within=300)


def test_after_the_fuzz_the_loop_ran_on_and_the_loads_unload_cleanly(fuzzed):
    fuzzed.check_both_kinds_came()
    state, node = fuzzed, fuzzed.node
    # the loop runs (a trigger may have deactivated it: activate it again)
    _call(state, "activate_rt_loop", {})
    before = len(state.infos)
    assert spin_until(node, lambda: len(state.infos) > before + 20, timeout=30)
    state.check_restarted_only_when_accepted(_spinning(state))

    def unload(name):
        answer = _call(state, "unload_component", {"name": name})
        return answer.result.successful, answer.result.reason

    state.unload_all(unload)
    proc = state.proc
    assert proc.poll() is None
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    assert proc.returncode == 0, "".join(state.said[-20:])
    assert not [x for x in state.said if "Traceback" in x or "Warning" in x], state.said
    # a doubled name is refused in the service's answer, without stopping the loop
    assert not [x for x in state.said if "already loaded" in x], state.said
    assert rtcf_shm_names() == []
