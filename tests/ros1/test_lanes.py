"""Lanes under ROS 1: an rt_launcher's ``_lane:=NAME`` puts its component in a worker
process of its own; its mapped outputs are published, and a mapped input that
components in several lanes read reaches each of them."""

import re

import pytest
from std_msgs.msg import Float64

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, rt_launcher, rt_runner

pytestmark = pytest.mark.integration


def test_a_lane_publishes_its_outputs_and_reads_what_ros_publishes(topics):
    r = rt_runner("/lanes", ros_mapping_whitelist="/ros/.*")
    launchers = []
    try:
        said = wait_for(r, "/lanes: ready", timeout=30)
        # /ros/lin: read in the main lane (a) and in lane "right" (b); /ros/lout: b's
        launchers.append(rt_launcher("/lanes", "la", "Mimo", "in1:=/ros/lin",
                                     "in2:=/ros/lin", "out1:=/lmid"))
        wait_for(launchers[-1], "loaded into", timeout=30)
        launchers.append(rt_launcher("/lanes", "lb", "Mimo", "in1:=/lmid", "in2:=/ros/lin",
                                     "out1:=/ros/lout", "_lane:=right"))
        wait_for(launchers[-1], "loaded into", timeout=30)
        said = wait_for(r, "loaded /lb", timeout=10)
        got = topics.sub("/ros/lout", Float64)
        pub = topics.pub("/ros/lin", Float64)
        for x in (7.0, -2.5):
            assert wait_until(
                lambda x=x: bool(got) and abs(got[-1].data - 3 * x) < 1e-9,
                20.0,
                publish=lambda x=x: pub.publish(Float64(x)),
            ), [m.data for m in got[-3:]]
    finally:
        end(*launchers)
        (err,) = end(r)
    assert r.returncode == 0, err
    assert "Traceback" not in err, err
    assert re.search(r"loaded /lb \(rtcf_examples.Mimo\) in lane 'right' \(pid \d+, ", said), said
