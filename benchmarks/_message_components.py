"""The rtcf components of ros_messages.py: a 7-joint arm's state written every iteration,
as a rosidl JointState, as a Serialized JointState, and as the same 21 numbers in one
float array.

Each keeps the numbers in one preallocated array (positions, velocities, efforts) and
moves them a little every iteration, in place, the same for all three; what differs is
only how they are written.
"""

from __future__ import annotations

import numpy as np

import rtcf

JOINTS = 7
NAMES = [f"joint{k + 1}" for k in range(JOINTS)]


class _ArmState(rtcf.Component):
    def configure(self) -> None:
        self.x = np.linspace(0.0, 1.0, 3 * JOINTS)
        self.q, self.v, self.e = self.x[:JOINTS], self.x[JOINTS:-JOINTS], self.x[-JOINTS:]
        self.setup()

    def setup(self) -> None:
        raise NotImplementedError

    def update(self) -> None:
        self.x += 1e-6  # new numbers, in place
        self.write()

    def write(self) -> None:
        raise NotImplementedError


class RosidlJointState(_ArmState):
    """A new sensor_msgs/JointState every iteration, stamped, from the arrays (what
    rtcf_examples' JointStateBroadcaster does); rclpy serializes it in the tap."""

    def setup(self) -> None:
        from sensor_msgs.msg import JointState

        self.message = JointState
        self.out = self.add_output("joint_states", JointState)

    def write(self) -> None:
        msg = self.message()
        self.stamp_to(msg.header.stamp)
        msg.name = NAMES
        msg.position = self.q.tolist()
        msg.velocity = self.v.tolist()
        msg.effort = self.e.tolist()
        self.out.write(msg)


class SerializedJointState(_ArmState):
    """One rtcf.Serialized JointState laid out here; the loop writes numbers into it."""

    def setup(self) -> None:
        from sensor_msgs.msg import JointState

        self.js = rtcf.Serialized(JointState, name=NAMES, position=JOINTS, velocity=JOINTS,
                                  effort=JOINTS)
        self.out = self.add_output("joint_states", JointState)

    def write(self) -> None:
        js = self.js
        js.stamp_ns = self.stamp_ns
        js.position[:] = self.q
        js.velocity[:] = self.v
        js.effort[:] = self.e
        self.out.write(js)


class FloatArray(_ArmState):
    """The same 21 numbers concatenated into one float64 array (std_msgs/Float64MultiArray
    on ROS 2)."""

    def setup(self) -> None:
        self.out = self.add_output("joint_states", np.ndarray)

    def write(self) -> None:
        self.out.write(np.concatenate((self.q, self.v, self.e)))
