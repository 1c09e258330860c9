"""Parameters, dynamic_reconfigure and logger levels with ROS 1 (``rtcf launch --middleware ros1``).

* At configure time components read private, namespace-relative and absolute names
  from one tree: the launch file's parameters and what the parameter server held
  (the launch file wins); the launch file's parameters land on the server.
* Tunable parameters are served by a dynamic_reconfigure server per component:
  ``dynparam set`` changes an output while the loop runs.
* rospy's ``~get_loggers``/``~set_logger_level`` (rqt_logger_level) list and set the
  component's logger ``ros.rtcf.<component>``, and the level reaches the worker.
"""

import subprocess

import pytest
import rospy
from roscpp.srv import GetLoggers, SetLoggerLevel
from rosgraph_msgs.msg import Log
from std_msgs.msg import String

from .. import _proc
from .._launches import launch_xml, launcher_xml, runner_xml, tuned_launch
from .._proc import start_rtcf, wait_for, wait_running
from ._helpers import wait_until
from ._launch import end, ros1_env, rt_launcher, rt_runner
from .conftest import rtcf_env

pytestmark = pytest.mark.integration

TUNED = tuned_launch("rtcf_ros1_components", "/ros/tuned_in", "/ros/tuned_out", offset=1)

# ParamReader writes each parameter it read on its own port: all mapped to /ros/reader/
READER = launch_xml(
    '<param name="absolute" value="launch-absolute"/>\n'
    '<group ns="cfg">\n  <param name="relative" value="launch-relative"/>'
    + launcher_xml(
        "reader",
        "rtcf_ros1_components ParamReader",
        {p: f"/ros/reader/{p}" for p in ("private", "relative", "absolute", "preset", "both")},
        private="launch-private",
        both="launch-both",
    )
    + "\n</group>",
    runner_xml(50.0, ros_mapping_whitelist="/ros/.*"),
)


def launch(tmp_path, text):
    path = tmp_path / "test.launch"
    path.write_text(text)
    proc = start_rtcf(rtcf_env(), "launch", path, "--middleware", "ros1")
    wait_running(proc)
    return proc


def stop(proc):
    return _proc.stop(proc)[1]


@pytest.fixture
def tuned(tmp_path, ros_node):
    proc = launch(tmp_path, TUNED)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            stop(proc)
        forget("/rt_runner", "/ctl")


def forget(*names):
    """Take what a test left on the parameter server off it (later tests read it)."""
    for name in names:
        if rospy.has_param(name):
            rospy.delete_param(name)


def dynparam(*args):
    """``rosrun dynamic_reconfigure dynparam ...``, as a user types it (scripts/setup-ros1
    installs rosbash and dynamic_reconfigure's manifest)."""
    done = subprocess.run(
        ["rosrun", "dynamic_reconfigure", "dynparam", *args],
        capture_output=True, text=True, env=ros1_env(), timeout=30,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_dynparam_set_changes_an_output_while_running(tuned, topics):
    probe = topics.float_probe("/ros/tuned_in", "/ros/tuned_out", 3.0)
    assert probe.answers(4.0), probe.out[-3:]
    # rosrun dynamic_reconfigure dynparam set: the standard tool
    dynparam("set", "/ctl/tuned", "gain", "2.5")
    assert probe.answers(8.5), probe.out[-3:]
    got = dynparam("get", "/ctl/tuned")
    assert "'gain': 2.5" in got and "'offset': 1" in got and "'mode': 'linear'" in got, got
    assert rospy.get_param("/ctl/tuned/gain") == 2.5  # as dynamic_reconfigure keeps it

    from dynamic_reconfigure.client import Client

    client = Client("/ctl/tuned", timeout=10)
    try:
        desc = {p["name"]: p for p in client.get_parameter_descriptions()}
        assert desc["gain"]["type"] == "double" and desc["gain"]["max"] == 100.0
        assert desc["offset"]["type"] == "int" and desc["offset"]["min"] == -1000
        assert desc["enabled"]["type"] == "bool"
        assert "'square'" in desc["mode"]["edit_method"]
        # dynamic_reconfigure clamps to the range before rtcf sees the value
        assert client.update_configuration({"gain": 500.0})["gain"] == 100.0
        assert probe.answers(301.0), probe.out[-3:]
        # not one of the choices: refused, the old value stays (and the reply says so)
        reply = client.update_configuration({"mode": "cubic"})
        assert reply["mode"] == "linear"
        reply = client.update_configuration({"mode": "square", "offset": -1})
        assert (reply["mode"], reply["offset"]) == ("square", -1)
        assert probe.answers(899.0), probe.out[-3:]
    finally:
        client.close()
    err = stop(tuned)
    assert "'cubic' is not one of 'linear', 'square'; keeping 'linear'" in err, err


def levels(runner="/rt_runner"):
    rospy.wait_for_service(f"{runner}/get_loggers", timeout=10)
    got = rospy.ServiceProxy(f"{runner}/get_loggers", GetLoggers)()
    return {lg.name: lg.level for lg in got.loggers}


def test_set_logger_level_reaches_the_worker(tuned, topics):
    records = topics.sub("/rosout", Log, queue_size=1000)
    assert records.connected()
    assert levels().get("ros.rtcf.ctl.tuned") == "INFO"
    mine = lambda word: [  # noqa: E731
        int(r.msg.split()[1]) for r in list(records)
        if r.name == "/ctl/tuned" and r.msg.startswith(word)
    ]
    assert wait_until(lambda: mine("info") and mine("warn"))
    # as rqt_logger_level calls it
    set_level = rospy.ServiceProxy("/rt_runner/set_logger_level", SetLoggerLevel)
    set_level(logger="ros.rtcf.ctl.tuned", level="warn")
    warned_before = len(mine("warn"))
    assert wait_until(lambda: len(mine("warn")) >= warned_before + 4)
    latest = mine("warn")[-3:]
    assert not set(latest) & set(mine("info")), (latest, mine("info")[-5:])
    assert levels().get("ros.rtcf.ctl.tuned") == "WARN"
    # and back: info records come again
    set_level(logger="ros.rtcf.ctl.tuned", level="info")
    assert wait_until(lambda: mine("info")[-1] > latest[-1])


def test_parameters_from_launch_file_and_server(tmp_path, topics):
    # set before the launch, as rosparam set would: one only on the server, one in both
    rospy.set_param("/cfg/reader/preset", "server-preset")
    rospy.set_param("/cfg/reader/both", "server-both")
    got = {k: topics.sub(f"/ros/reader/{k}", String) for k in (
        "private", "relative", "absolute", "preset", "both"
    )}
    proc = launch(tmp_path, READER)
    try:
        assert all(r.connected() for r in got.values())
        assert wait_until(lambda: all(got.values()))
        values = {k: r[-1].data for k, r in got.items()}
        assert values == {
            "private": "launch-private",
            "relative": "launch-relative",
            "absolute": "launch-absolute",
            "preset": "server-preset",
            "both": "launch-both",  # the launch file wins, as with roslaunch
        }
        # and the launch file's parameters are on the server, as roslaunch puts them
        assert rospy.get_param("/cfg/reader/private") == "launch-private"
        assert rospy.get_param("/cfg/relative") == "launch-relative"
        assert rospy.get_param("/absolute") == "launch-absolute"
        assert rospy.get_param("/cfg/reader/both") == "launch-both"
        assert rospy.get_param("/rt_runner/frequency") == 50.0
    finally:
        stop(proc)
        forget("/cfg", "/absolute", "/rt_runner")


def test_executables_mode_reads_the_server_and_serves_dynparam(topics):
    # rt_runner and an rt_launcher, no roslaunch: the launcher's private parameter comes
    # from the server (rosparam set before), the reconfigure server lives in the runner
    rospy.set_param("/exe/tuned/offset", 5)
    runner = rt_runner("/exe/rt_runner", ros_mapping_whitelist="/ros/.*")
    launcher = rt_launcher(
        "/exe/rt_runner", "tuned", "Tuned", "in:=/ros/exe_in", "out:=/ros/exe_out",
        "__ns:=/exe", package="rtcf_ros1_components",
    )
    try:
        wait_for(launcher, "loaded into", timeout=30)
        probe = topics.float_probe("/ros/exe_in", "/ros/exe_out", 2.0)
        assert probe.answers(7.0), probe.out[-3:]
        dynparam("set", "/exe/tuned", "gain", "-3.0")
        assert probe.answers(-1.0), probe.out[-3:]
        assert "'gain': -3.0" in dynparam("get", "/exe/tuned")
    finally:
        end(launcher, runner)
        forget("/exe")
