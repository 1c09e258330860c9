"""rtcf component_list/component_info/connection_list/connection_info/component_order
against a running runner, through its ~/introspect service."""

import json
import subprocess
import sys

import pytest

from .conftest import rtcf_env
from .test_topics import launched

pytestmark = pytest.mark.integration


RUNNER = ["--runner", "/rtcf/rt_runner"]  # sum_test.launch's runner, in namespace /rtcf


def rtcf(*args):
    if "--runner" not in args:
        args = (*args, *RUNNER)
    proc = subprocess.run(
        [sys.executable, "-m", "rtcf", *args], capture_output=True, text=True,
        env=rtcf_env(), timeout=60, stdin=subprocess.DEVNULL,
    )
    return proc.returncode, proc.stdout, proc.stderr


@pytest.fixture(scope="module")
def sum_test():
    with launched("rtcf_examples", "sum_test.launch") as proc:
        yield proc


def test_component_list_and_order(sum_test):
    code, out, err = rtcf("component_list")
    assert code == 0, err
    names = [line.split()[0] for line in out.splitlines()]
    assert names == ["/rtcf/sum1", "/rtcf/sum2"]
    assert "rtcf_examples" in out
    code, out, err = rtcf("component_order")
    assert code == 0, err
    assert out.splitlines() == ["1. /rtcf/sum1", "2. /rtcf/sum2"]


def test_connections_say_which_reach_ros(sum_test):
    code, out, err = rtcf("connection_list", "--json")
    assert code == 0, err
    conns = {c["topic"]: c for c in json.loads(out)["connections"]}
    assert conns["/rtcf/ros/in"]["ros"] and conns["/rtcf/ros/out"]["ros"]
    assert not conns["/rtcf/ros/blacklisted"]["ros"]
    code, out, err = rtcf("connection_info", "/rtcf/ros/in")
    assert code == 0, err
    assert "subscribers: /rtcf/sum1" in out and "mapped to ROS: yes" in out
    assert "publishers: (none in the runner)" in out


def test_component_info_shows_ports_and_log_level(sum_test):
    code, out, err = rtcf("component_info", "rtcf/sum2")
    assert code == 0, err
    assert out.startswith("/rtcf/sum2  (rtcf_examples")
    assert "-> /rtcf/ros/out" in out and "log level: info" in out


def test_unknown_names_and_absent_runners_are_one_line_errors(sum_test):
    code, _, err = rtcf("component_info", "/rtcf/nope")
    assert code == 1
    assert "no component '/rtcf/nope' (loaded: /rtcf/sum1, /rtcf/sum2)" in err
    code, _, err = rtcf("component_list", "--runner", "/nobody", "--timeout", "2")
    assert code == 1
    assert "no runner answers at /nobody/introspect within 2 s" in err
    assert len(err.strip().splitlines()) == 1
