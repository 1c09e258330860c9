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
        self.odometry_message, self.transform_message, self.tf_message = messages
        self.next_publish_ns = -1

    def add_ports(self) -> None:
        """Declare ``~odom`` and ``/tf`` on the component (in its ``configure``), and make
        a first message of each type: it loads its type support (an import), here and
        not in the loop."""
        component, tf_message = self._component, self.tf_message
        self.odom = component.add_output("~odom", self.odometry_message)
        self.tf = component.add_output("/tf", tf_message) if tf_message is not None else None
        self._odometry_message(0.0, 0.0, 0.0, 1.0)
        if tf_message is not None:
            tf_message(transforms=[self.transform_message()])

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
        message = self._odometry_message(odometry.x, odometry.y, qz, qw)
        self.odom.write(message)
        if self.tf is not None:
            transform = self.transform_message()
            transform.header.stamp = message.header.stamp
            transform.header.frame_id = self.odom_frame
            transform.child_frame_id = self.base_frame
            transform.transform.translation.x = odometry.x
            transform.transform.translation.y = odometry.y
            transform.transform.rotation.z = qz
            transform.transform.rotation.w = qw
            self.tf.write(self.tf_message(transforms=[transform]))

    def _odometry_message(self, x: float, y: float, qz: float, qw: float) -> Any:
        # a new message per write (publish_rate, 50 Hz): an in-process reader may
        # still hold the last one
        message = self.odometry_message()
        self._component.stamp_to(message.header.stamp)
        message.header.frame_id = self.odom_frame
        message.child_frame_id = self.base_frame
        pose = message.pose
        pose.pose.position.x, pose.pose.position.y = x, y
        pose.pose.orientation.z, pose.pose.orientation.w = qz, qw
        pose.covariance = self.pose_covariance
        twist = message.twist
        twist.twist.linear.x, twist.twist.angular.z = self._odometry.linear, self._odometry.angular
        twist.covariance = self.twist_covariance
        return message
