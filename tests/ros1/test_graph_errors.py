"""A load that breaks the graph is refused, and the rt_runner runs on with the others.

The original logged a failed dependency resolution and ran an empty loop; an
rt_runner here refuses the load that closes a cycle (or adds a second producer to a
topic that is read), with the reason, and keeps the components it had.
"""

import json

import pytest
import rospy
from std_srvs.srv import Trigger

from .._proc import end_after_each_test, read_rest, wait_for
from ._launch import end
from .test_nodes import STARTED, launcher, runner

pytestmark = pytest.mark.integration


_end_all = end_after_each_test(STARTED, end, launchers_first=True)


def loaded(runner_name):
    answer = rospy.ServiceProxy(f"{runner_name}/introspect", Trigger)()
    return [c["name"] for c in json.loads(answer.message)["components"]]


def refused(launcher_proc):
    """What a launcher said that its runner refused (it ends with exit 1)."""
    _, err = read_rest(launcher_proc, timeout=60)
    assert launcher_proc.returncode == 1, err
    return err


def test_a_cycle_or_a_second_producer_is_refused_and_the_runner_keeps_running(ros_node):
    r = runner("/rgraph")
    x = launcher("/rgraph", "x", "Identity", "in_port:=/b", "out_port:=/a")
    wait_for(x, "loaded into", timeout=30)
    err = refused(launcher("/rgraph", "y", "Identity", "in_port:=/a", "out_port:=/b"))
    assert "refused to load rtcf_examples.Identity" in err
    assert "cycle in the data flow: /x -[/a]-> /y -[/b]-> /x" in err
    ok = launcher("/rgraph", "ok", "Identity", "in_port:=/a", "out_port:=/d")
    wait_for(ok, "loaded into", timeout=30)
    # /x writes /a, which /ok reads: a second writer is refused
    err = refused(launcher("/rgraph", "z", "Identity", "in_port:=/c", "out_port:=/a"))
    assert "topic '/a' has 2 producers" in err
    assert r.poll() is None  # the runner runs on, with what it had
    assert sorted(loaded("/rgraph")) == ["/ok", "/x"]
