"""The diffbot from outside (rtcf launch rtcf_examples diffbot.launch --middleware ros2),
with rclpy doing what teleop and nav2 do: geometry_msgs/TwistStamped on
/diffbot_base_controller/cmd_vel, nav_msgs/Odometry read from its ~/odom and odom ->
base_link from /tf; MujocoDiffbot's ground truth from /diffbot/base_pose."""

import math
import time

import pytest
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64MultiArray
from tf2_msgs.msg import TFMessage

from ..._proc import interrupt, wait_for
from ..conftest import start_rtcf
from ..test_topics import spin_until

pytestmark = pytest.mark.integration

TIMEOUT = 0.5  # diffbot_controllers.yaml's cmd_vel_timeout


def stamp_s(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def test_cmd_vel_drives_the_base_odom_follows_it_and_it_stops_after_the_timeout(ros_node):
    proc = start_rtcf("launch", "rtcf_examples", "diffbot.launch", "--middleware", "ros2")
    try:
        wait_for(proc, "running until Ctrl-C", timeout=60)
        odoms, tfs, truths = [], [], []
        ros_node.create_subscription(Odometry, "/diffbot_base_controller/odom", odoms.append, 100)
        ros_node.create_subscription(TFMessage, "/tf", tfs.append, 100)
        ros_node.create_subscription(Float64MultiArray, "/diffbot/base_pose", truths.append, 10)
        pub = ros_node.create_publisher(TwistStamped, "/diffbot_base_controller/cmd_vel", 10)
        assert spin_until(ros_node, lambda: odoms and tfs and truths, timeout=30)

        sent = []

        def teleop():  # 0.5 m/s, stamped now, every 20 ms (teleop's 50 Hz)
            now = ros_node.get_clock().now()
            if sent and (now.nanoseconds - sent[-1]) < 20_000_000:
                return
            message = TwistStamped()
            message.header.stamp = now.to_msg()
            message.twist.linear.x = 0.5
            pub.publish(message)
            sent.append(now.nanoseconds)

        start = time.monotonic()
        spin_until(ros_node, lambda: time.monotonic() - start > 2.0, timeout=5, publish=teleop)
        last = sent[-1] * 1e-9  # the last command's stamp

        def standing():
            return stamp_s(odoms[-1].header.stamp) > last and abs(
                odoms[-1].twist.twist.linear.x) < 0.01

        assert spin_until(ros_node, standing, timeout=10)
        moving = [m for m in odoms if stamp_s(m.header.stamp) > last]
        stopped = next(
            stamp_s(m.header.stamp) for m in moving if abs(m.twist.twist.linear.x) < 0.01
        )
        # the last command holds for cmd_vel_timeout, then the controller commands zero
        # (within a period) and the wheels' servos stop the base (about 0.1 s)
        assert all(m.twist.twist.linear.x > 0.45 for m in moving
                   if stamp_s(m.header.stamp) < last + TIMEOUT)
        assert last + TIMEOUT < stopped < last + TIMEOUT + 0.25

        # standing still: the odometry against MuJoCo's ground truth
        spin_until(ros_node, lambda: False, timeout=0.3)
        x, y, _ = truths[-1].data
        position = odoms[-1].pose.pose.position
        assert math.hypot(x, y) > 1.0  # about 0.5 m/s for 2.5 s
        assert math.hypot(position.x - x, position.y - y) < 0.02 * math.hypot(x, y)
        (transform,) = tfs[-1].transforms
        assert (transform.header.frame_id, transform.child_frame_id) == ("odom", "base_link")
        assert transform.transform.translation.x == pytest.approx(position.x, abs=1e-9)
        types = dict(ros_node.get_topic_names_and_types())
        assert types["/tf"] == ["tf2_msgs/msg/TFMessage"]
        assert types["/diffbot_base_controller/odom"] == ["nav_msgs/msg/Odometry"]
    finally:
        _, err = interrupt(proc)
    assert proc.returncode == 0, err
    assert "velocity command timed out: braking" in err
