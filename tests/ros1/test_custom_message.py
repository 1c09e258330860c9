"""A message type of the user's own, end to end: the original's Identity example.

rtcf_example_msgs/Custom (ros1/rtcf_example_msgs, generated with genpy by
scripts/setup-ros1) holds two doubles and a geometry_msgs/Point. It comes in on
/mapped/in, crosses identity1, the runner-internal /mapped/tmp and identity2, and
goes out on /mapped/out, with every field as it was.
"""

import json

import pytest
import rosgraph
import rospy
from geometry_msgs.msg import Point
from rtcf_example_msgs.msg import Custom  # fails loudly where it was not generated
from std_srvs.srv import Trigger

from .._proc import wait_for
from ._helpers import wait_until
from ._launch import end, roslaunch, rtcf_launch

pytestmark = pytest.mark.integration

SENT = Custom(a=1.0 / 3.0, b=-2.5e-300, point=Point(x=1e300, y=-0.0, z=42.0))


def round_trip(topics):
    got = topics.sub("/mapped/out", Custom)
    pub = topics.pub("/mapped/in", Custom)
    assert wait_until(lambda: bool(got), 20.0, publish=lambda: pub.publish(SENT)), (
        "nothing came out on /mapped/out"
    )
    out = got[-1]
    assert (out.a, out.b) == (SENT.a, SENT.b)
    assert (out.point.x, out.point.y, out.point.z) == (1e300, -0.0, 42.0)
    assert str(out.point.y) == "-0.0"  # bit for bit, the sign of zero too


def check_graph():
    types = dict(rosgraph.Master("/rtcf_test").getTopicTypes())
    assert types["/mapped/out"] == "rtcf_example_msgs/Custom"
    assert types["/mapped/in"] == "rtcf_example_msgs/Custom"
    assert "/mapped/tmp" not in types  # blacklisted: it stays inside the runner
    answer = rospy.ServiceProxy("/rt_runner/introspect", Trigger)()
    data = json.loads(answer.message)
    ports = {
        (c["name"], p["name"]): (p["topic"], p["type"])
        for c in data["components"] for p in c["inputs"] + c["outputs"]
    }
    assert ports[("/identity1", "out_port")] == ("/mapped/tmp", "rtcf_example_msgs/Custom")
    assert ports[("/identity2", "in_port")] == ("/mapped/tmp", "rtcf_example_msgs/Custom")
    assert data["order"] == ["/identity1", "/identity2"]


@pytest.mark.parametrize("how", ["roslaunch", "rtcf launch"])
def test_custom_message_through_the_identity_example(topics, how):
    if how == "roslaunch":
        proc = roslaunch("rtcf_examples", "custom_message.launch")
        running = "/rt_runner: running"
    else:
        proc = rtcf_launch("rtcf_examples", "custom_message.launch")
        running = "running until Ctrl-C"
    try:
        wait_for(proc, running, timeout=30)
        round_trip(topics)
        check_graph()
    finally:
        (err,) = end(proc)
    assert "Traceback" not in err, err
