"""diff_drive_controller's odometry going out: ``~/odom`` (nav_msgs/Odometry) and ``/tf``
(tf2_msgs/TFMessage, ``enable_odom_tf``) at ``publish_rate``, with their frames and
covariances.

The controller turns twists into wheel speeds and integrates the odometry
(``_odometry.Odometry``); what of it is published, in which frames and when is held
here, apart from that. The message classes come in from the controller (imported in its
``configure``), so this module imports no ROS package.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

import rtcf

from ._odometry import Odometry
from ._params import ControllerParameters


def frames(p: ControllerParameters, namespace: str) -> tuple[str, str]:
    """odom_frame_id and base_frame_id with the tf prefix: tf_frame_prefix, or the
    namespace when it is empty; never a leading '/', always a trailing one."""
    prefix = ""
    if p.flag("tf_frame_prefix_enable", True):
        prefix = p.text("tf_frame_prefix", "") or namespace
        if not prefix.endswith("/"):
            prefix += "/"
        if prefix.startswith("/"):
            prefix = prefix[1:]
    odom, base = p.text("odom_frame_id", "odom"), p.text("base_frame_id", "base_link")
    return prefix + odom, prefix + base


class OdometryPublisher:
    """Publishes one controller's ``odometry`` on ``~/odom`` and ``/tf`` (``tf_message``
    None: no /tf) once every ``publish_period_ns``, the first time on the first
    ``publish_due`` after ``reset``."""

    def __init__(
        self,
        component: rtcf.Component,
        odometry: Odometry,
        frame_ids: tuple[str, str],
        covariances: Sequence[Sequence[float]],
        publish_period_ns: int,
        messages: tuple[Any, Any, Any],
    ) -> None:
        self._component = component
        self._odometry = odometry
        self.odom_frame, self.base_frame = frame_ids
        self.pose_covariance = np.diag(covariances[0]).reshape(36)
        self.twist_covariance = np.diag(covariances[1]).reshape(36)
        self.publish_period_ns = publish_period_ns
        # (TransformStamped, the third, is laid out inside the TFMessage)
        self.odometry_message, _, self.tf_message = messages
        self.next_publish_ns = -1

    def add_ports(self) -> None:
        """Declare ``~odom`` and ``/tf`` on the component (in its ``configure``), and lay
        their messages out: each an ``rtcf.Serialized`` (its frames and covariances
        fixed), whose pose, twist and stamp a publication stores through numpy views
        into its bytes before writing the same object again (in-process readers:
        docs/ros2.md "Writing messages in the loop")."""
        component, tf_message = self._component, self.tf_message
        self.odom = component.add_output("~odom", self.odometry_message)
        self.tf = component.add_output("/tf", tf_message) if tf_message is not None else None
        odom = rtcf.Serialized(
            self.odometry_message, child_frame_id=self.base_frame,
            **{"header.frame_id": self.odom_frame, "pose.covariance": self.pose_covariance,
               "twist.covariance": self.twist_covariance, "pose.pose.orientation.w": 1.0})
        self.odom_message = odom
        self.position = odom.view("pose.pose.position")  # x, y, z
        self.orientation = odom.view("pose.pose.orientation")  # x, y, z, w
        self.linear = odom.view("twist.twist.linear")
        self.angular = odom.view("twist.twist.angular")
        if tf_message is not None:
            tf = rtcf.Serialized(tf_message, transforms=[{
                "header": {"frame_id": self.odom_frame}, "child_frame_id": self.base_frame,
                "transform": {"rotation": {"w": 1.0}},
            }])
            self.tf_out = tf
            self.translation = tf.view("transforms[0].transform.translation")
            self.rotation = tf.view("transforms[0].transform.rotation")
            self.stamp_tf = tf.stamp_setter("transforms[0].header.stamp")

    def reset(self) -> None:
        """The next ``publish_due`` publishes."""
        self.next_publish_ns = -1

    def publish_due(self, now: int) -> None:
        """Publish if a period has passed since the last publication (``now``: ns)."""
        if now > self.next_publish_ns:
            if self.next_publish_ns < 0:
                self.next_publish_ns = now
            self.next_publish_ns += self.publish_period_ns
            self._publish()

    def _publish(self) -> None:
        odometry = self._odometry
        half = odometry.heading * 0.5
        qz, qw = math.sin(half), math.cos(half)
        x, y = odometry.x, odometry.y
        odom = self.odom_message
        stamp_ns = self._component.stamp_ns
        odom.stamp_ns = stamp_ns
        position, orientation = self.position, self.orientation
        position[0] = x
        position[1] = y
        orientation[2] = qz
        orientation[3] = qw
        self.linear[0] = odometry.linear
        self.angular[2] = odometry.angular
        self.odom.write(odom)
        if self.tf is not None:
            self.stamp_tf(stamp_ns)
            translation, rotation = self.translation, self.rotation
            translation[0] = x
            translation[1] = y
            rotation[2] = qz
            rotation[3] = qw
            self.tf.write(self.tf_out)
