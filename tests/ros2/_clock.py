"""/clock from the test process, for a loop on use_sim_time: its messages, a publisher,
and time stepped forward until the loop has run a number of periods."""

from builtin_interfaces.msg import Time
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from .test_topics import spin_until

STEP_NS = 50_000_000  # half a period at 10 Hz


def clock_msg(ns):
    return Clock(clock=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000))


def clock_publisher(ros_node):
    """A /clock publisher as simulators have them: best effort, depth 1."""
    return ros_node.create_publisher(
        Clock, "/clock", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
    )


def step_clock(ros_node, pub, iterations, periods, start_ns=50 * 10**9):
    """Publish /clock at ``start_ns`` until the loop's iteration 0 shows at the end of
    ``iterations`` (best effort: discovery may still be matching the two sides), then
    ``periods`` periods of a 10 Hz loop in steps of 50 ms, until iteration ``periods``
    shows; then spin half a second more, in which nothing may run."""
    assert spin_until(ros_node, lambda: iterations[-1:] == [0],
                      publish=lambda: pub.publish(clock_msg(start_ns))), iterations
    for k in range(1, 2 * periods + 1):
        pub.publish(clock_msg(start_ns + k * STEP_NS))
        spin_until(ros_node, lambda: False, timeout=0.05)
    assert spin_until(ros_node, lambda: iterations[-1:] == [periods]), iterations
    spin_until(ros_node, lambda: False, timeout=0.5)
