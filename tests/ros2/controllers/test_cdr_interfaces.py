"""rtcf.Serialized for what the controllers publish on the interfaces PyPI lacks
(control_msgs, tf2_msgs: built by scripts/setup-ros2, Python 3.11 only): the action's
feedback, the controllers' states, /tf. rclpy reads our bytes back as the message, and
its own bytes are ours but for padding.
"""

import numpy as np
import pytest
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import (
    JointTrajectoryControllerState,
    MultiDOFCommand,
    MultiDOFStateStamped,
)
from geometry_msgs.msg import TransformStamped
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage

from rtcf import Serialized
from rtcf._core._cdr import example_fields
from rtcf._runtime._codec import codec_for

RNG = np.random.default_rng(7)
NAMES = [f"joint{k + 1}" for k in range(7)]


def _agrees(ours: Serialized, expected) -> None:
    assert deserialize_message(bytes(ours), type(expected)) == expected
    assert ours.same_but_padding(serialize_message(expected))


@pytest.mark.parametrize("cls", [
    FollowJointTrajectory.Feedback, FollowJointTrajectory.Result, FollowJointTrajectory.Goal,
    JointTrajectoryControllerState, MultiDOFCommand, MultiDOFStateStamped, TFMessage,
])
def test_every_field_of_the_controllers_messages(cls):
    codec_for(cls)  # the codec's own check passes
    ours = Serialized(cls, **example_fields(cls))
    _agrees(ours, ours.to_message())


def test_the_trajectory_feedback_of_seven_joints():
    point = {"positions": 7, "velocities": 7, "accelerations": 0, "effort": 0}
    fb = Serialized(FollowJointTrajectory.Feedback, joint_names=NAMES, desired=point,
                    actual=point, error=point, **{"header.frame_id": ""})
    values = RNG.normal(size=(6, 7))
    for k, field in enumerate(("desired", "actual", "error")):
        getattr(fb, field).positions[:] = values[2 * k]
        getattr(fb, field).velocities[:] = values[2 * k + 1]
    fb.view("desired.time_from_start.sec")[0] = 2
    fb.stamp_ns = 1_700_000_000_000_000_001
    expected = FollowJointTrajectory.Feedback(joint_names=NAMES)
    expected.header.stamp.sec, expected.header.stamp.nanosec = 1_700_000_000, 1
    for k, field in enumerate(("desired", "actual", "error")):
        p = getattr(expected, field)
        p.positions, p.velocities = values[2 * k].tolist(), values[2 * k + 1].tolist()
    expected.desired.time_from_start.sec = 2
    _agrees(fb, expected)


def test_tf_odom_to_base_link():
    tf = Serialized(TFMessage, transforms=[
        {"header": {"frame_id": "odom"}, "child_frame_id": "base_link"}
    ])
    stamp = tf.stamp_setter("transforms[0].header.stamp")
    stamp(1_700_000_000_500_000_000)
    tf.view("transforms[0].transform.translation")[:] = (1.0, 2.0, 0.0)
    tf.view("transforms[0].transform.rotation")[:] = (0.0, 0.0, 0.6, 0.8)
    t = TransformStamped(child_frame_id="base_link")
    t.header.frame_id = "odom"
    t.header.stamp.sec, t.header.stamp.nanosec = 1_700_000_000, 500_000_000
    t.transform.translation.x, t.transform.translation.y = 1.0, 2.0
    t.transform.rotation.z, t.transform.rotation.w = 0.6, 0.8
    _agrees(tf, TFMessage(transforms=[t]))
