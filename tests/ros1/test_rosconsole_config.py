"""ROSCONSOLE_CONFIG_FILE on ROS 1: the original's logging.launch, unchanged in meaning.

logging.launch sets the variable with <env> to rosconsole_settings.conf, which puts
the component loggin_test at DEBUG: its debug records reach /rosout, which they do
not at the default level (info). A file that sets ros.rtcf to WARN keeps a
component's debug and info records from being made at all.
"""

from pathlib import Path

import pytest
import rospy
from roscpp.srv import GetLoggers
from rosgraph_msgs.msg import Log

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, roslaunch, rtcf_launch, start
from .conftest import PORT

pytestmark = pytest.mark.integration

WARN_LAUNCH = Path(__file__).parent / "fixtures" / "launch" / "rosconsole_warn.launch"


def levels_of(records, node, at_least=2):
    """The /rosout levels of ``node``'s records, once iteration ``at_least - 1`` logged."""
    mine = lambda: [r for r in records if r.name == node]  # noqa: E731
    last = f"Test RT fatal at iteration {at_least - 1}"
    assert wait_until(lambda: any(r.msg == last for r in mine()), timeout=20), [
        (r.name, r.msg) for r in records
    ]
    return mine()


@pytest.mark.parametrize("how", ["roslaunch", "rtcf launch"])
def test_logging_launch_sets_its_component_to_debug(topics, how):
    records = topics.sub("/rosout_agg", Log, queue_size=1000)
    assert records.connected()
    if how == "roslaunch":
        proc, running = roslaunch("rtcf_examples", "logging.launch"), "/rt_runner: running"
    else:
        proc, running = rtcf_launch("rtcf_examples", "logging.launch"), "running until Ctrl-C"
    try:
        err = wait_for(proc, running, timeout=30)
        assert "rosconsole_settings.conf" in err
        mine = levels_of(records, "/loggin_test")
        seen = {(r.level, r.msg) for r in mine}
        assert (Log.DEBUG, "Test RT debug at iteration 0") in seen
        assert (Log.DEBUG, "Test RT debug at iteration 1") in seen
        assert (Log.DEBUG, "Test non-RT debug with number 12345") in seen  # configure()
        if how == "roslaunch":
            # rqt_logger_level shows the component as its launcher's node, at DEBUG
            rospy.wait_for_service("/loggin_test/get_loggers", timeout=10)
            loggers = rospy.ServiceProxy("/loggin_test/get_loggers", GetLoggers)().loggers
            assert {x.name: x.level for x in loggers}["ros.rtcf.loggin_test"] == "DEBUG"
    finally:
        end(proc)


def test_a_file_that_sets_ros_rtcf_to_warn_keeps_debug_and_info_from_being_made(topics):
    records = topics.sub("/rosout_agg", Log, queue_size=1000)
    assert records.connected()
    proc = start("roslaunch", "--screen", "-p", PORT, WARN_LAUNCH)
    try:
        wait_for(proc, "/rt_runner: running", timeout=30)
        mine = levels_of(records, "/warned", at_least=3)
        assert {r.level for r in mine} == {Log.WARN, Log.ERROR, Log.FATAL}
    finally:
        end(proc)
