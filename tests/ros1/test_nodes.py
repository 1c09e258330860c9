"""rt_runner and rt_launcher (ros1/rtcf) as separate ROS 1 processes, without roslaunch."""

import signal
import subprocess
import sys
import time

import pytest
import rospy
from roscpp.srv import GetLoggers, SetLoggerLevel
from rosgraph_msgs.msg import Log
from rtcf_msgs.srv import GetRunnerInfo, LoadComponent, LoadComponentRequest
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from .._proc import end_after_each_test, read_rest, wait_for
from ._helpers import wait_until
from ._launch import BIN, end, ros1_env, rt_launcher, rt_runner, start

pytestmark = pytest.mark.integration

STARTED = []
_end_all = end_after_each_test(STARTED, end)


def runner(name, **params):
    proc = rt_runner(name, **params)
    STARTED.append(proc)
    wait_for(proc, f"{name}: ready", timeout=30)
    return proc


def launcher(runner_name, name, cls, *remaps, first=False, package="rtcf_examples"):
    proc = rt_launcher(runner_name, name, cls, *remaps, first=first, package=package)
    STARTED.append(proc)
    return proc


def sum3(runner_name, prefix):
    """Two Mimo launchers: /ros/PREFIXout = 3 * /ros/PREFIXin, as in the SumTest."""
    a = launcher(runner_name, f"{prefix}a", "Mimo", f"in1:=/ros/{prefix}in",
                 f"in2:=/ros/{prefix}in", f"out1:=/{prefix}mid")
    b = launcher(runner_name, f"{prefix}b", "Mimo", f"in1:=/{prefix}mid",
                 f"in2:=/ros/{prefix}in", f"out1:=/ros/{prefix}out")
    for p in (a, b):
        wait_for(p, "loaded into", timeout=30)
    return a, b


def triples(topics, prefix, value):
    got = topics.sub(f"/ros/{prefix}out", Float64)
    pub = topics.pub(f"/ros/{prefix}in", Float64)
    return wait_until(
        lambda: bool(got) and abs(got[-1].data - 3 * value) < 1e-9,
        10.0,
        publish=lambda: pub.publish(Float64(value)),
    )


def test_two_runners_share_one_master(topics):
    runner("/r1", ros_mapping_whitelist="/ros/.*")
    runner("/r2", ros_mapping_whitelist="/ros/.*")
    sum3("/r1", "one")
    sum3("/r2", "two")
    assert triples(topics, "one", 2.0)
    assert triples(topics, "two", -7.5)
    for name in ("/r1", "/r2"):
        info = rospy.ServiceProxy(f"{name}/get_runner_info", GetRunnerInfo)().runner_info
        prefix = "one" if name == "/r1" else "two"
        assert sorted(c.name for c in info.components) == [f"/{prefix}a", f"/{prefix}b"]
        # the wiring first: the order follows from it (a -> b through /PREFIXmid)
        comp = next(c for c in info.components if c.name == f"/{prefix}a")
        assert (comp.package, comp.type) == ("rtcf_examples", "Mimo")
        port = next(p for p in comp.input_ports if p.name_unresolved == "in1")
        assert port.name_remapped == f"/ros/{prefix}in" and port.connected_to_ROS, info
        mid = next(c for c in info.connections if c.name == f"/{prefix}mid")
        assert list(mid.publishing_components) == [f"/{prefix}a"], info
        assert list(mid.subscribing_components) == [f"/{prefix}b"], info
        assert not mid.connected_to_ROS
        assert list(info.component_order) == [f"/{prefix}a", f"/{prefix}b"], info


def test_bad_load_requests_are_refused_and_the_runner_keeps_running(topics):
    runner("/rbad", ros_mapping_whitelist="/ros/.*")
    sum3("/rbad", "bad")
    load = rospy.ServiceProxy("/rbad/load_component", LoadComponent)
    answer = load(LoadComponentRequest(package="", type="Mimo", name="x"))
    assert answer.message == "load_component: missing field(s) package", answer.message
    answer = load(LoadComponentRequest(package="rtcf_examples", type="Mimo", name="n" * 5000))
    assert not answer.success and answer.message.startswith(
        "load_component: field 'name' got 'nnn"), answer.message
    assert "of at most 255 characters" in answer.message
    answer = load(LoadComponentRequest(package="os; import this", type="X", name="y"))
    assert "field 'package' got 'os; import this' (str); it wants a Python module name" in (
        answer.message), answer.message
    answer = load(LoadComponentRequest(package="no_such_module", type="X", name="y"))
    assert not answer.success and "no_such_module" in answer.message, answer.message
    answer = load(LoadComponentRequest(package="rtcf_examples", type="Mimo", name="z",
                                       remaps=["in1"]))
    assert not answer.success and "from:=to" in answer.message, answer.message
    assert triples(topics, "bad", 1.5)  # still running, both components in place


def test_a_stopped_launcher_unloads_its_component(ros_node):
    r = runner("/rstop")
    a = launcher("/rstop", "comp", "Identity")
    wait_for(a, "loaded into", timeout=30)
    wait_for(r, "/rstop: running", timeout=30)
    a.send_signal(signal.SIGINT)
    _, err = read_rest(a, timeout=15)
    assert a.returncode == 0 and "unloaded from /rstop" in err, err
    wait_for(r, "/rstop: unloaded /comp", timeout=10)


def test_a_killed_launcher_gets_its_component_unloaded(ros_node):
    r = runner("/rkill")
    a = launcher("/rkill", "victim", "Identity")
    wait_for(a, "loaded into", timeout=30)
    a.kill()
    a.wait()
    wait_for(r, "/rkill: unloaded /victim", timeout=15)


def test_launchers_of_a_stopped_runner_exit_with_a_clear_message(ros_node):
    r = runner("/rgone")
    a = launcher("/rgone", "orphan", "Identity")
    wait_for(a, "loaded into", timeout=30)
    r.send_signal(signal.SIGINT)
    _, rerr = read_rest(r, timeout=30)
    assert r.returncode == 0, rerr
    _, err = read_rest(a, timeout=15)
    assert a.returncode == 1 and "the runner /rgone is gone" in err, err


def test_a_launcher_without_runner_finds_the_nearest_from_its_namespace_up(ros_node):
    """As arm.launch has them: launchers in a group below their runner, no ~runner."""
    runner("/up/rt_runner")
    a = start(BIN / "rt_launcher", "rtcf_examples", "Identity", "__name:=deep",
              "__ns:=/up/arm/wrist")
    STARTED.append(a)
    said = wait_for(a, "loaded into", timeout=30)
    assert "rt_launcher /up/arm/wrist/deep: loaded into /up/rt_runner" in said, said


def test_a_launcher_stopped_while_it_waits_for_a_runner_exits_quietly(ros_node):
    a = start(BIN / "rt_launcher", "rtcf_examples", "Identity", "__name:=early",
              "__ns:=/nobody/here")
    time.sleep(2.0)  # waiting for /nobody/here/rt_runner, /nobody/rt_runner, /rt_runner
    a.send_signal(signal.SIGINT)
    _, err = read_rest(a, timeout=15)
    assert a.returncode == 0, err
    assert "stopped before a runner answered" in err and "Traceback" not in err, err


def test_a_refused_launcher_exits_1_with_the_reason(ros_node):
    runner("/rref")
    a = launcher("/rref", "nothing", "NoSuchClass")
    _, err = read_rest(a, timeout=30)
    assert a.returncode == 1, err
    assert "/rref refused to load rtcf_examples.NoSuchClass" in err, err


def test_wait_for_trigger_is_activated_and_deactivated(topics):
    r = runner("/rtrig", mode="wait_for_trigger", ros_mapping_whitelist="/ros/.*")
    sum3("/rtrig", "trig")
    time.sleep(0.5)
    assert "/rtrig: running" not in wait_for(r, "loaded /trigb", timeout=10)
    assert rospy.ServiceProxy("/rtrig/activate_rt_loop", Trigger)().success
    wait_for(r, "/rtrig: running", timeout=10)
    assert triples(topics, "trig", 4.0)
    assert rospy.ServiceProxy("/rtrig/deactivate_rt_loop", Trigger)().success


def test_rtcf_component_list_asks_a_ros1_runner(ros_node):
    runner("/rcli", ros_mapping_whitelist="/ros/.*")
    sum3("/rcli", "cli")
    rtcf = [sys.executable, "-m", "rtcf"]
    out = subprocess.run(
        [*rtcf, "component_list", "--middleware", "ros1", "--runner", "/rcli"],
        capture_output=True, text=True, env=ros1_env(), timeout=60,
    )
    assert out.returncode == 0, out.stderr
    assert "/clia" in out.stdout and "rtcf_examples.Mimo" in out.stdout, out.stdout
    out = subprocess.run(
        [*rtcf, "component_order", "--middleware", "ros1", "--runner", "/rcli"],
        capture_output=True, text=True, env=ros1_env(), timeout=60,
    )
    assert out.stdout.split() == ["1.", "/clia", "2.", "/clib"], out.stdout


def loggers(node):
    got = rospy.ServiceProxy(f"{node}/get_loggers", GetLoggers)()
    return {lg.name: lg.level for lg in got.loggers}


def test_rqt_logger_level_on_a_launcher_reaches_its_component(topics):
    # rqt_logger_level shows the component as its launcher's node (/ctl/tuned): the
    # launcher lists ros.rtcf.ctl.tuned and forwards a level set there to the runner
    records = topics.sub("/rosout", Log, queue_size=1000)
    runner("/rlog")
    a = launcher("/rlog", "tuned", "Tuned", "__ns:=/ctl", package="rtcf_ros1_components")
    wait_for(a, "loaded into", timeout=30)
    assert loggers("/ctl/tuned").get("ros.rtcf.ctl.tuned") == "INFO"
    mine = lambda word: [  # noqa: E731
        int(r.msg.split()[1]) for r in list(records)
        if r.name == "/ctl/tuned" and r.msg.startswith(word + " ")
    ]
    assert wait_until(lambda: mine("info") and mine("warn"))
    # as rqt_logger_level calls it, on the node it shows
    set_level = rospy.ServiceProxy("/ctl/tuned/set_logger_level", SetLoggerLevel)
    set_level(logger="ros.rtcf.ctl.tuned", level="warn")
    assert loggers("/ctl/tuned").get("ros.rtcf.ctl.tuned") == "WARN"
    assert loggers("/rlog").get("ros.rtcf.ctl.tuned") == "WARN"  # the runner's copy
    warned = len(mine("warn"))
    assert wait_until(lambda: len(mine("warn")) >= warned + 4)
    latest = mine("warn")[-3:]
    assert not set(latest) & set(mine("info")), (latest, mine("info")[-5:])
    set_level(logger="ros.rtcf.ctl.tuned", level="info")  # and back: info comes again
    assert wait_until(lambda: mine("info") and mine("info")[-1] > latest[-1])
    # the runner's service refuses what is no level, or no component of its own
    direct = rospy.ServiceProxy("/rlog/set_component_log_level", SetLoggerLevel)
    with pytest.raises(rospy.ServiceException, match="unknown log level"):
        direct(logger="/ctl/tuned", level="loud")
    with pytest.raises(rospy.ServiceException, match="not loaded"):
        direct(logger="/ctl/other", level="warn")
