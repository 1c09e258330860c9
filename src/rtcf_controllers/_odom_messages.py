"""diff_drive_controller's ``~/odom`` and ``/tf`` as their bytes, written in the loop.

Both messages have a shape fixed at configure time (the frames, the covariances), so
each is an ``rtcf.Serialized`` laid out once; a publication stores the pose, the
twist and the stamp through numpy views into the bytes and writes the same object
(in-process readers see it as the message; docs/ros2.md "Writing messages in the
loop").
"""

from __future__ import annotations

from typing import Any

import numpy as np

import rtcf


class OdomMessages:
    """The Odometry (and, with a TFMessage class, the odom -> base transform) of a
    base, written to ``odom`` (and ``tf``)."""

    def __init__(self, odometry: type, tf_message: type | None, odom_frame: str,
                 base_frame: str, pose_covariance: np.ndarray,
                 twist_covariance: np.ndarray) -> None:
        self.odom = rtcf.Serialized(
            odometry, child_frame_id=base_frame,
            **{"header.frame_id": odom_frame, "pose.covariance": pose_covariance,
               "twist.covariance": twist_covariance, "pose.pose.orientation.w": 1.0})
        self.position = self.odom.view("pose.pose.position")  # x, y, z
        self.orientation = self.odom.view("pose.pose.orientation")  # x, y, z, w
        self.linear = self.odom.view("twist.twist.linear")
        self.angular = self.odom.view("twist.twist.angular")
        self.tf: Any = None
        if tf_message is not None:
            self.tf = rtcf.Serialized(tf_message, transforms=[{
                "header": {"frame_id": odom_frame}, "child_frame_id": base_frame,
                "transform": {"rotation": {"w": 1.0}},
            }])
            self.translation = self.tf.view("transforms[0].transform.translation")
            self.rotation = self.tf.view("transforms[0].transform.rotation")
            self.stamp_tf = self.tf.stamp_setter("transforms[0].header.stamp")

    def write(self, odom_port: Any, tf_port: Any, stamp_ns: int, x: float, y: float,
              qz: float, qw: float, linear: float, angular: float) -> None:
        """The pose (x, y, heading as qz, qw) and twist, stamped, to both ports."""
        odom = self.odom
        odom.stamp_ns = stamp_ns
        position, orientation = self.position, self.orientation
        position[0] = x
        position[1] = y
        orientation[2] = qz
        orientation[3] = qw
        self.linear[0] = linear
        self.angular[2] = angular
        odom_port.write(odom)
        if tf_port is not None:
            self.stamp_tf(stamp_ns)
            translation, rotation = self.translation, self.rotation
            translation[0] = x
            translation[1] = y
            rotation[2] = qz
            rotation[3] = qw
            tf_port.write(self.tf)
