"""A running ROS 1 rt_runner against a thousand generated requests (hypothesis), and
a locked one (docs/security.md). LoadComponent's fields are typed by its .srv, so the
fuzz is in their values: names, modules, classes, remaps and regexes of any text.

Checked: every request is answered, in one line without a traceback; the runner stays
up and its loop runs on; a refused load (a module or class that does not exist, a
doubled name) does not stop the loop (its /diagnostics "loop starts"); loads that were
accepted unload cleanly; a locked runner keeps its components, and loads only modules
its allowed_modules name.
"""

import string
import time

import pytest
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rtcf_msgs.srv import (
    LoadComponent,
    LoadComponentRequest,
    UnloadComponent,
    UnloadComponentRequest,
)
from std_srvs.srv import Trigger

from .._proc import rtcf_shm_names, wait_for
from .test_nodes import STARTED, end, launcher, runner

pytestmark = pytest.mark.integration

TEXT = st.one_of(
    st.text(max_size=40), st.text(string.printable, min_size=200, max_size=6000),
    st.sampled_from(["rtcf_examples", "Mimo", "Identity", "Pid", "os", "/x", "in1:=/x", "(",
                     ".*", "", "a b", "rtcf_examples.Mimo", "__init__"]),
)
NAMES = st.text(string.ascii_letters + "_", min_size=1, max_size=12)
LOAD = st.one_of(
    st.builds(LoadComponentRequest, package=TEXT, type=TEXT, name=TEXT, namespace=TEXT,
              remaps=st.lists(TEXT, max_size=3), is_first=st.booleans(),
              topics_ignore_for_graph=TEXT, launcher=TEXT),
    st.builds(LoadComponentRequest, package=st.just("rtcf_examples"),
              type=st.sampled_from(["Mimo", "Identity", "Pid"]),
              name=NAMES.map(lambda n: f"f_{n}")),
)
REQUEST = st.one_of(
    st.tuples(st.just("load"), LOAD),
    st.tuples(st.just("unload"), st.builds(UnloadComponentRequest, name=TEXT)),
    st.tuples(st.sampled_from(["activate", "deactivate"]), st.none()),
)


@pytest.fixture(scope="module")
def fuzzed(ros_node):
    proc = runner("/fuzzed")
    STARTED.remove(proc)  # this module's own: it outlives each test
    proxies = {
        "load": rospy.ServiceProxy("/fuzzed/load_component", LoadComponent, persistent=True),
        "unload": rospy.ServiceProxy("/fuzzed/unload_component", UnloadComponent,
                                     persistent=True),
        "activate": rospy.ServiceProxy("/fuzzed/activate_rt_loop", Trigger),
        "deactivate": rospy.ServiceProxy("/fuzzed/deactivate_rt_loop", Trigger),
    }
    for p in proxies.values():
        p.wait_for_service(timeout=20)
    starts = []  # (when, the runner's "loop starts") from its /diagnostics
    sub = rospy.Subscriber(
        "/diagnostics", DiagnosticArray,
        lambda m: starts.extend((time.monotonic(), int(kv.value)) for s in m.status
                                if s.name == "rtcf: /fuzzed" for kv in s.values
                                if kv.key == "loop starts"), queue_size=100)
    state = {"proc": proc, "proxies": proxies, "answered": 0, "loaded": set(), "refused": 0,
             "starts": starts}
    try:
        yield state
    finally:
        sub.unregister()
        for p in proxies.values():
            p.close()
        end(proc)


def _loop_starts(state):
    """The runner's "loop starts", as its /diagnostics say it after this moment."""
    asked = time.monotonic()
    deadline = asked + 30
    while not any(t > asked for t, _ in state["starts"]):
        assert time.monotonic() < deadline, "no /diagnostics from the runner"
        time.sleep(0.05)
    return state["starts"][-1][1]


def test_refused_loads_are_answered_without_stopping_the_loop(fuzzed):
    load = fuzzed["proxies"]["load"]
    good = {"package": "rtcf_examples", "type": "Mimo", "name": "held"}
    assert load(LoadComponentRequest(**good)).success
    before = _loop_starts(fuzzed)
    for fields, said in (
        (dict(good, package="no_such_module", name="a"), "module 'no_such_module' is not found"),
        (dict(good, package="rtcf_examples.nope", name="b"),
         "module 'rtcf_examples.nope' is not found"),
        (dict(good, type="NoSuchClass", name="c"), "has no class 'NoSuchClass'"),
        (good, "is already loaded"),
        (dict(good, name="d", remaps=["x"]), "remap"),
    ):
        answer = load(LoadComponentRequest(**fields))
        assert not answer.success and said in answer.message, (fields, answer.message)
    assert _loop_starts(fuzzed) == before, "a refused load stopped the loop"
    # the count does see a real stop: a load (with none loaded, no loop runs to say it)
    assert load(LoadComponentRequest(**dict(good, name="held2"))).success
    assert _loop_starts(fuzzed) > before
    assert fuzzed["proxies"]["unload"](UnloadComponentRequest(name="held2")).success
    fuzzed["loaded"].add("/held")


@settings(max_examples=1000, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.data_too_large])
@given(request=REQUEST)
def test_a_thousand_generated_requests_are_each_answered(fuzzed, request):
    kind, req = request
    if "first" not in fuzzed:
        fuzzed["first"] = _loop_starts(fuzzed)
    proxy = fuzzed["proxies"][kind]
    answer = proxy(req) if req is not None else proxy()
    fuzzed["answered"] += 1
    if answer.success:
        fuzzed["accepted"] = fuzzed.get("accepted", 0) + 1  # may stop and start the loop
    assert fuzzed["proc"].poll() is None, "the runner ended"
    if kind == "load":
        assert "Traceback" not in answer.message and "\n" not in answer.message, answer.message
        if answer.success:
            namespace = "/" + req.namespace.strip("/") if req.namespace.strip("/") else ""
            fuzzed["loaded"].add(f"{namespace}/{req.name}")
        else:
            fuzzed["refused"] += 1


def test_after_the_fuzz_the_loads_unload_cleanly(fuzzed):
    assert fuzzed["answered"] >= 1000
    assert len(fuzzed["loaded"]) >= 10 and fuzzed["refused"] >= 100, (
        len(fuzzed["loaded"]), fuzzed["refused"])
    fuzzed["proxies"]["activate"]()
    # stopped and started again only for what was accepted, not for the many refusals
    assert _loop_starts(fuzzed) - fuzzed["first"] <= fuzzed["accepted"] + 1, (
        fuzzed["first"], fuzzed["starts"][-1], fuzzed["accepted"], fuzzed["refused"])
    for name in sorted(fuzzed["loaded"]):
        answer = fuzzed["proxies"]["unload"](UnloadComponentRequest(name=name))
        assert answer.success or "is not loaded" in answer.message, (name, answer.message)
    proc = fuzzed["proc"]
    assert proc.poll() is None
    [err] = end(proc)
    assert proc.returncode == 0, err
    assert "Traceback" not in err, err
    assert "already loaded" not in err, err  # refused in the service, the loop not stopped
    assert rtcf_shm_names() == []


def test_a_locked_runner_keeps_its_components_and_loads_only_allowed_modules(ros_node):
    r = runner("/locked", mode="wait_for_components", num_components_expected=2,
               lock="structure", allowed_modules="rtcf_examples")
    a = launcher("/locked", "la", "Mimo")
    b = launcher("/locked", "lb", "Mimo")
    wait_for(a, "loaded into", timeout=30)
    wait_for(b, "loaded into", timeout=30)
    wait_for(r, "/locked: running", timeout=30)  # the loop runs, and with it the lock
    load = rospy.ServiceProxy("/locked/load_component", LoadComponent)
    answer = load(LoadComponentRequest(package="os", type="system", name="evil"))
    assert not answer.success
    assert answer.message == ("runner /locked: module 'os' is not in its allowed_modules "
                              "(rtcf_examples)")
    unload = rospy.ServiceProxy("/locked/unload_component", UnloadComponent)
    answer = unload(UnloadComponentRequest(name="/la"))
    assert not answer.success and answer.message == (
        "runner /locked is locked (lock structure): it refuses unloads while its loop "
        "runs; its launch file or parameters set lock")
