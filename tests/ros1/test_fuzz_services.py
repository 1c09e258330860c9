"""A running ROS 1 rt_runner against a thousand generated requests (hypothesis), and
a locked one (docs/security.md). LoadComponent's fields are typed by its .srv, so the
fuzz is in their values: names, modules, classes, remaps and regexes of any text.

Checked: every request is answered, in one line without a traceback; the runner stays
up and its loop runs on; loads that were accepted unload cleanly; a locked runner
keeps its components, and loads only modules its allowed_modules name.
"""

import string

import pytest
import rospy
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
    state = {"proc": proc, "proxies": proxies, "answered": 0, "loaded": set(), "refused": 0}
    try:
        yield state
    finally:
        for p in proxies.values():
            p.close()
        end(proc)


@settings(max_examples=1000, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.data_too_large])
@given(request=REQUEST)
def test_a_thousand_generated_requests_are_each_answered(fuzzed, request):
    kind, req = request
    proxy = fuzzed["proxies"][kind]
    answer = proxy(req) if req is not None else proxy()
    fuzzed["answered"] += 1
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
