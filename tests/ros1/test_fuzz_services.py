"""A running ROS 1 rt_runner against a thousand generated requests (hypothesis), and
a locked one (docs/security.md). LoadComponent's fields are typed by its .srv, so the
fuzz is in their values: names, modules, classes, remaps and regexes of any text.

Checked: every request is answered, in one line without a traceback; the runner stays
up and its loop runs on; a refused load (a module or class that does not exist, a
doubled name) does not stop the loop (its /diagnostics "loop starts"); loads that were
accepted unload cleanly; a locked runner keeps its components, and loads only modules
its allowed_modules name.
"""

import pytest
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import given
from hypothesis import strategies as st
from rtcf_msgs.srv import (
    LoadComponent,
    LoadComponentRequest,
    UnloadComponent,
    UnloadComponentRequest,
)
from std_srvs.srv import Trigger

from .._fuzz import CLASSES, GOOD, GOOD_NAMES, LONG_TEXT, REFUSALS, SHORT_TEXT, THOUSAND, Tally
from .._proc import rtcf_shm_names, wait_for
from ._helpers import wait_until
from .test_nodes import STARTED, end, launcher, runner

pytestmark = pytest.mark.integration

TEXT = st.one_of(
    SHORT_TEXT, LONG_TEXT,
    st.sampled_from(["rtcf_examples", "Mimo", "Identity", "Pid", "os", "/x", "in1:=/x", "(",
                     ".*", "", "a b", "rtcf_examples.Mimo", "__init__"]),
)
LOAD = st.one_of(
    st.builds(LoadComponentRequest, package=TEXT, type=TEXT, name=TEXT, namespace=TEXT,
              remaps=st.lists(TEXT, max_size=3), is_first=st.booleans(),
              topics_ignore_for_graph=TEXT, launcher=TEXT),
    st.builds(LoadComponentRequest, package=st.just("rtcf_examples"),
              type=st.sampled_from(CLASSES), name=GOOD_NAMES),
)
REQUEST = st.one_of(
    st.tuples(st.just("load"), LOAD),
    st.tuples(st.just("unload"), st.builds(UnloadComponentRequest, name=TEXT)),
    st.tuples(st.sampled_from(["activate", "deactivate"]), st.none()),
)


def _load_request(fields):
    """The neutral fields of tests/_fuzz.py as LoadComponent's (package, type)."""
    fields = dict(fields)
    return LoadComponentRequest(package=fields.pop("module"), type=fields.pop("class"),
                                **fields)


@pytest.fixture(scope="module")
def fuzzed(ros_node):
    proc = runner("/fuzzed")
    STARTED.remove(proc)  # this module's own: it outlives each test
    tally = Tally(proc, "/fuzzed")
    tally.proxies = {
        "load": rospy.ServiceProxy("/fuzzed/load_component", LoadComponent, persistent=True),
        "unload": rospy.ServiceProxy("/fuzzed/unload_component", UnloadComponent,
                                     persistent=True),
        "activate": rospy.ServiceProxy("/fuzzed/activate_rt_loop", Trigger),
        "deactivate": rospy.ServiceProxy("/fuzzed/deactivate_rt_loop", Trigger),
    }
    for p in tally.proxies.values():
        p.wait_for_service(timeout=20)
    sub = rospy.Subscriber("/diagnostics", DiagnosticArray, tally.seen, queue_size=100)
    try:
        yield tally
    finally:
        sub.unregister()
        for p in tally.proxies.values():
            p.close()
        end(proc)


def test_refused_loads_are_answered_without_stopping_the_loop(fuzzed):
    load = fuzzed.proxies["load"]
    assert load(_load_request(GOOD)).success
    before = fuzzed.loop_starts(wait_until)
    for what, (fields, said) in REFUSALS.items():
        answer = load(_load_request(fields))
        assert not answer.success and said in answer.message, (what, fields, answer.message)
    assert fuzzed.loop_starts(wait_until) == before, "a refused load stopped the loop"
    # the count does see a real stop: a load (with none loaded, no loop runs to say it)
    assert load(_load_request(dict(GOOD, name="held2"))).success
    assert fuzzed.loop_starts(wait_until) > before
    assert fuzzed.proxies["unload"](UnloadComponentRequest(name="held2")).success
    fuzzed.loaded.add("/held")


@THOUSAND
@given(request=REQUEST)
def test_a_thousand_generated_requests_are_each_answered(fuzzed, request):
    kind, req = request
    if fuzzed.first is None:
        fuzzed.first = fuzzed.loop_starts(wait_until)
    proxy = fuzzed.proxies[kind]
    answer = proxy(req) if req is not None else proxy()
    fuzzed.answered += 1
    if answer.success:
        fuzzed.accepted += 1  # may stop and start the loop
    assert fuzzed.proc.poll() is None, "the runner ended"
    if kind == "load":
        namespace = "/" + req.namespace.strip("/") if req.namespace.strip("/") else ""
        fuzzed.load_answered(f"{namespace}/{req.name}", answer.success, answer.message)


def test_after_the_fuzz_the_loads_unload_cleanly(fuzzed):
    fuzzed.check_both_kinds_came()
    fuzzed.proxies["activate"]()
    fuzzed.check_restarted_only_when_accepted(wait_until)

    def unload(name):
        answer = fuzzed.proxies["unload"](UnloadComponentRequest(name=name))
        return answer.success, answer.message

    fuzzed.unload_all(unload)
    proc = fuzzed.proc
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
