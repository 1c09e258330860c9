"""ROS 2's equivalent of ROSCONSOLE_CONFIG_FILE: --ros-args --log-level <logger>:=<level>.

Given to an rt_launcher, it sets its component's start level (before configure, so
configure's records count too); given to the rt_runner, it sets the level of the
components it loads, as a component container's --log-level does for the nodes
composed into it. A launcher's own setting wins over its runner's.
"""

import pytest
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from .._proc import end_after_each_test, wait_for
from .test_nodes import STARTED, end, start
from .test_topics import spin_until

pytestmark = pytest.mark.integration

ALL = {Log.DEBUG, Log.INFO, Log.WARN, Log.ERROR, Log.FATAL}


_end_all = end_after_each_test(STARTED, end, launchers_first=True)


def launcher(name, *ros_args, namespace="/"):
    args = ["rtcf_examples", "Logging", "--ros-args", "-r", f"__node:={name}",
            "-r", f"__ns:={namespace}", "-p", "runner:=/rt_runner", *ros_args]
    return start("rt_launcher", *args)


def test_log_level_arguments_set_components_start_levels(ros_node):
    records = []
    qos = QoSProfile(
        depth=1000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    ros_node.create_subscription(Log, "/rosout", records.append, qos)
    # the runner's own: every component under /arm at debug, except where a launcher says
    r = start("rt_runner", "--ros-args", "-r", "__node:=rt_runner", "-p", "mode:=no_wait",
              "-p", "frequency:=2.0", "--log-level", "arm:=debug")
    wait_for(r, "ready")
    loud = launcher("loud", "--log-level", "loud:=debug")
    quiet = launcher("quiet", "--log-level", "quiet:=error")
    plain = launcher("plain")
    via_runner = launcher("via_runner", namespace="/arm")
    overridden = launcher("overridden", "--log-level", "arm.overridden:=warn", namespace="/arm")
    for p in (loud, quiet, plain, via_runner, overridden):
        wait_for(p, "loaded into")

    def levels(logger):
        return {r.level for r in records if r.name == logger}

    def ran_twice(logger):  # iterations count on across the loads: any two will do
        return sum(r.name == logger and r.msg.startswith("Test RT fatal") for r in records) >= 2

    names = ("loud", "quiet", "plain", "arm.via_runner", "arm.overridden")
    assert spin_until(ros_node, lambda: all(ran_twice(n) for n in names), timeout=30), {
        n: levels(n) for n in names
    }
    assert levels("loud") == ALL
    assert any(
        r.name == "loud" and r.level == Log.DEBUG and r.msg == "Test non-RT debug with number 12345"
        for r in records
    )  # configure's records: the level was there before configure ran
    assert levels("quiet") == {Log.ERROR, Log.FATAL}
    assert levels("plain") == ALL - {Log.DEBUG}  # the runner's default, info
    assert levels("arm.via_runner") == ALL  # the runner's --log-level arm:=debug
    assert levels("arm.overridden") == {Log.WARN, Log.ERROR, Log.FATAL}  # the launcher's
