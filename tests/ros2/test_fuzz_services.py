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
import string
import threading
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.parameter import Parameter as PyParameter
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from .._proc import rtcf_shm_names, wait_for
from .test_nodes import end, runner
from .test_topics import spin_until

pytestmark = pytest.mark.integration

RUNNER = "fuzzed"
SERVICES = ("load_component", "unload_component", "tune_component", "lifecycle_component")
CLASSES = ("Mimo", "Identity", "Pid", "NoSuchClass", "")
FIELDS = ("module", "class", "name", "namespace", "remaps", "is_first", "launcher",
          "topics_ignore_for_graph", "log_level", "transition", "param.gain", "param.kp",
          "lane", "", "param.", "x" * 300)
NAMES = st.text(string.ascii_letters + "_", min_size=1, max_size=12)
VALUES = st.one_of(
    st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(allow_nan=False),
    st.text(max_size=40), st.text(string.printable, min_size=200, max_size=6000),
    st.lists(st.text(max_size=12), max_size=4),
    st.lists(st.integers(-(2**63), 2**63 - 1), max_size=4),
    st.lists(st.booleans(), max_size=3), st.lists(st.floats(allow_nan=False), max_size=3),
    st.sampled_from(["rtcf_examples", "os", "Mimo", "in1:=/x", "deactivate", "activate"]),
)
# a well-formed load now and then: it must load, run, and unload again
GOOD_LOAD = st.fixed_dictionaries({
    "module": st.just("rtcf_examples"), "class": st.sampled_from(CLASSES[:3]),
    "name": NAMES.map(lambda n: f"f_{n}"),
})
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
    infos = []
    node.create_subscription(Float64MultiArray, f"/{RUNNER}/iteration_info",
                             lambda m: infos.append(int(m.data[0])), 1000)
    clients = {s: node.create_client(SetParametersAtomically, f"/{RUNNER}/{s}")
               for s in SERVICES}
    clients.update({s: node.create_client(Trigger, f"/{RUNNER}/{s}")
                    for s in ("activate_rt_loop", "deactivate_rt_loop")})
    starts = []  # (when, the runner's "loop starts") from its /diagnostics
    node.create_subscription(
        DiagnosticArray, "/diagnostics",
        lambda m: starts.extend((time.monotonic(), int(kv.value)) for st in m.status
                                if st.name == f"rtcf: /{RUNNER}" for kv in st.values
                                if kv.key == "loop starts"), 100)
    state = {"node": node, "proc": proc, "clients": clients, "infos": infos,
             "answered": 0, "loaded": set(), "refused": 0, "accepted": 0, "starts": starts}
    try:
        wait_for(proc, "ready")
        said = []  # the runner's lines, read on: a full pipe would block it
        reader = threading.Thread(target=lambda: said.extend(iter(proc.stderr.readline, "")),
                                  daemon=True)
        reader.start()
        state["said"] = said
        assert all(c.wait_for_service(timeout_sec=20) for c in clients.values())
        yield state
    finally:
        end(proc)
        node.destroy_node()
        rclpy.shutdown(context=context)


def _loop_starts(state):
    """The runner's "loop starts", as its /diagnostics say it after this moment."""
    asked = time.monotonic()
    assert spin_until(state["node"], lambda: any(t > asked for t, _ in state["starts"]),
                      timeout=30), "no /diagnostics from the runner"
    return state["starts"][-1][1]


def test_refused_loads_are_answered_without_stopping_the_loop(fuzzed):
    """Each of these is refused by the service itself: the loop runs through them on its
    time grid. A load that is not refused does stop it (to import and configure)."""
    good = {"module": "rtcf_examples", "class": "Mimo", "name": "held"}
    assert _call(fuzzed, "load_component", good).result.successful
    before = _loop_starts(fuzzed)
    refusals = {
        "no such module": ({"module": "no_such_module", "class": "Mimo", "name": "a"},
                           "module 'no_such_module' is not found"),
        "no such submodule": ({"module": "rtcf_examples.nope", "class": "Mimo", "name": "b"},
                              "module 'rtcf_examples.nope' is not found"),
        "no such class": ({"module": "rtcf_examples", "class": "NoSuchClass", "name": "c"},
                          "has no class 'NoSuchClass'"),
        "a doubled name": (good, "is already loaded"),
        "a malformed remap": (dict(good, name="d", remaps=["x"]), "remap"),
        "a malformed field": (dict(good, name="e", is_first="yes"), "is_first"),
    }
    for what, (fields, said) in refusals.items():
        answer = _call(fuzzed, "load_component", fields)
        assert not answer.result.successful, what
        assert said in answer.result.reason, (what, answer.result.reason)
    assert _loop_starts(fuzzed) == before, "a refused load stopped the loop"
    # the count does see a real stop: a load (with none loaded, no loop runs to say it)
    assert _call(fuzzed, "load_component", dict(good, name="held2")).result.successful
    assert _loop_starts(fuzzed) > before
    assert _call(fuzzed, "unload_component", {"name": "held2"}).result.successful
    fuzzed["loaded"].add("/held")  # kept through the fuzz: a loop runs to say its starts


def _call(state, service, fields):
    client = state["clients"][service]
    if service.endswith("_rt_loop"):
        request = Trigger.Request()
    else:
        request = SetParametersAtomically.Request()
        request.parameters = [_parameter(k, v) for k, v in fields.items()]
    future = client.call_async(request)
    assert spin_until(state["node"], future.done, timeout=60), (service, fields)
    return future.result()


@settings(max_examples=1000, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.data_too_large])
@given(request=REQUEST)
def test_a_thousand_generated_requests_are_each_answered(fuzzed, request):
    service, fields = request
    if "first" not in fuzzed:
        fuzzed["first"] = _loop_starts(fuzzed)
    answer = _call(fuzzed, service, fields)
    assert answer is not None
    fuzzed["answered"] += 1
    assert fuzzed["proc"].poll() is None, "the runner ended"
    if service.endswith("_rt_loop") or answer.result.successful:
        fuzzed["accepted"] += 1  # may stop the loop and start it again
    if service == "load_component":
        ok = answer.result.successful
        reason = answer.result.reason
        assert "Traceback" not in reason and "\n" not in reason[:300], reason
        if ok:
            fuzzed["loaded"].add(f"/{fields['name']}")
        else:
            fuzzed["refused"] += 1


def test_after_the_fuzz_the_loop_ran_on_and_the_loads_unload_cleanly(fuzzed):
    assert fuzzed["answered"] >= 1000
    # both kinds came: loads that ran, and many refused (malformed, unknown, doubled)
    assert len(fuzzed["loaded"]) >= 10 and fuzzed["refused"] >= 100, (
        len(fuzzed["loaded"]), fuzzed["refused"])
    state, node = fuzzed, fuzzed["node"]
    # the loop runs (a trigger may have deactivated it: activate it again)
    _call(state, "activate_rt_loop", {})
    before = len(state["infos"])
    assert spin_until(node, lambda: len(state["infos"]) > before + 20, timeout=30)
    # stopped and started again only for what was accepted, not for the many refusals
    first = state["first"]
    assert _loop_starts(state) - first <= state["accepted"] + 1, (
        first, state["starts"][-1], state["accepted"], state["refused"])
    for name in sorted(state["loaded"]):
        answer = _call(state, "unload_component", {"name": name})
        assert answer.result.successful or "is not loaded" in answer.result.reason, (
            name, answer.result.reason)
    proc = state["proc"]
    assert proc.poll() is None
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    assert proc.returncode == 0, "".join(state["said"][-20:])
    assert not [x for x in state["said"] if "Traceback" in x or "Warning" in x], state["said"]
    # a doubled name is refused in the service's answer, without stopping the loop
    assert not [x for x in state["said"] if "already loaded" in x], state["said"]
    assert rtcf_shm_names() == []
