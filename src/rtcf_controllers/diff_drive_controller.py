"""ros2_controllers' diff_drive_controller as an rtcf component (docs/controllers.md).

Velocity commands for a differential-drive base (``~/cmd_vel``) become wheel speeds;
odometry from the wheels is published on ``~/odom`` and ``/tf``. Parameter names,
defaults and behaviour are those of the Jazzy release's
``diff_drive_controller_parameter.yaml`` and ``diff_drive_controller.cpp``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rtcf

from ._odometry import Odometry
from ._odometry_publisher import OdometryPublisher, frames
from ._params import ControllerParameters
from ._speed_limiter import speed_limiter
from ._throttle import Throttled

_NS = 1_000_000_000
_THROTTLE_NS = _NS  # ros2_controllers' warnings in the loop: at most one a second


def _import_messages(enable_odom_tf: bool) -> tuple[Any, Any, Any, Any]:
    try:
        from geometry_msgs.msg import TransformStamped, TwistStamped
        from nav_msgs.msg import Odometry as OdometryMessage
    except ImportError:
        raise rtcf.ConfigurationError(
            "DiffDriveController needs geometry_msgs and nav_msgs: pip install 'rtcf[ros2]' "
            "(or source ROS 2)"
        ) from None
    tf_message = None
    if enable_odom_tf:
        try:
            from tf2_msgs.msg import TFMessage
        except ImportError:
            raise rtcf.ConfigurationError(
                "DiffDriveController's /tf (enable_odom_tf: true) needs tf2_msgs, which PyPI "
                "lacks: set up with bash scripts/setup-ros2 (docs/ros2.md), or set "
                "enable_odom_tf: false"
            ) from None
        tf_message = TFMessage
    return TwistStamped, OdometryMessage, TransformStamped, tf_message


class DiffDriveController(rtcf.ChainableComponent):
    """diff_drive_controller/DiffDriveController: a base's twist to its wheels' speeds,
    and odometry back.

    Ports (ros2_control's interfaces, one float64 array, a value per wheel in the order
    ``left_wheel_names`` then ``right_wheel_names``): ``velocity_command`` [rad/s]
    out; ``position`` [rad] in (``position_feedback: true``, the default) or
    ``velocity`` [rad/s] (``false``), neither with ``open_loop: true``.
    Topics: ``~/cmd_vel`` (geometry_msgs/TwistStamped) in; ``~/odom``
    (nav_msgs/Odometry) and ``/tf`` (tf2_msgs/TFMessage, ``enable_odom_tf``) out at
    ``publish_rate``; ``~/cmd_vel_out`` (the limited command,
    ``publish_limited_velocity``).

    Chainable as in Jazzy: its reference interfaces ``<name>/linear/velocity`` and
    ``<name>/angular/velocity``; chained, a preceding controller writes them and
    ``~/cmd_vel`` (and its timeout) is not read.

    A ``~/cmd_vel`` whose ``linear.x`` or ``angular.z`` (the fields it uses) is not
    finite is ignored: counted in ``refused_messages``, logged at most once a second,
    and ``cmd_vel_timeout`` applies as if it had not arrived.
    """

    ros2_control_type = "diff_drive_controller/DiffDriveController"

    def configure(self) -> None:
        p = ControllerParameters(self)
        self.left_names = p.names("left_wheel_names", non_empty=True)
        self.right_names = p.names("right_wheel_names", non_empty=True)
        if len(self.left_names) != len(self.right_names):
            raise rtcf.ConfigurationError(
                f"component {self.full_name!r}: {len(self.left_names)} left wheels and "
                f"{len(self.right_names)} right wheels: give as many on each side"
            )
        self.wheels_per_side = len(self.left_names)
        separation = p.number("wheel_separation", positive=True)
        radius = p.number("wheel_radius", positive=True)
        self.separation = p.number("wheel_separation_multiplier", 1.0) * separation
        self.left_radius = p.number("left_wheel_radius_multiplier", 1.0) * radius
        self.right_radius = p.number("right_wheel_radius_multiplier", 1.0) * radius
        self.open_loop = p.flag("open_loop", False)
        self.position_feedback = p.flag("position_feedback", True)
        self.enable_odom_tf = p.flag("enable_odom_tf", True)
        self.publish_limited_velocity = p.flag("publish_limited_velocity", False)
        timeout = p.number("cmd_vel_timeout", 0.5)
        self.timeout_ns = round(timeout * _NS) if timeout > 0.0 else 0  # 0: no timeout
        publish_rate = p.number("publish_rate", 50.0, positive=True)
        self.publish_period_ns = round(_NS / publish_rate)
        window = p.integer("velocity_rolling_window_size", 10)
        kinds = ("pose", "twist")
        covariances = [p.numbers(f"{kind}_covariance_diagonal", [0.0] * 6) for kind in kinds]
        for kind, diagonal in zip(kinds, covariances, strict=True):
            if len(diagonal) != 6:
                raise rtcf.ConfigurationError(
                    f"component {self.full_name!r}: {kind}_covariance_diagonal has "
                    f"{len(diagonal)} numbers; give 6 (x, y, z, roll, pitch, yaw)"
                )
        self.linear_limiter = speed_limiter(p, self, "linear.x")
        self.angular_limiter = speed_limiter(p, self, "angular.z")
        frame_ids = frames(p, self.namespace)

        twist, odometry, transform, tf_message = _import_messages(self.enable_odom_tf)
        self.twist_message = twist
        self.odometry = Odometry(self.separation, self.left_radius, self.right_radius, window)
        self.publisher = OdometryPublisher(self, self.odometry, frame_ids, covariances,
                                           self.publish_period_ns,
                                           (odometry, transform, tf_message))

        self.cmd_vel = self.add_input("~cmd_vel", twist)
        # Jazzy's reference interfaces: what the wheels follow (linear, angular)
        self.references = self.add_reference_interfaces(["linear/velocity", "angular/velocity"])
        wheels = [*self.left_names, *self.right_names]  # ros2_control's <wheel>/<interface>
        self.velocity_command = self.add_command_interfaces(
            "velocity_command", [f"{wheel}/velocity" for wheel in wheels])
        self.feedback = None
        if not self.open_loop:
            interface = "position" if self.position_feedback else "velocity"
            self.feedback = self.add_state_interfaces(
                interface, [f"{wheel}/{interface}" for wheel in wheels])
        self.publisher.add_ports()  # ~odom and /tf
        self.cmd_vel_out = (
            self.add_output("~cmd_vel_out", twist) if self.publish_limited_velocity else None
        )
        twist()  # its first message loads its type support (an import): not in the loop
        self.refused_messages = {"~/cmd_vel": 0}  # what was refused, for tests and reports
        self.not_finite = Throttled(self)
        self.reset()

    def reset(self) -> None:
        """The odometry back to the origin (configure, cleanup), and the buffers."""
        self.odometry.reset()
        self.reset_buffers()

    def reset_buffers(self) -> None:
        """No command yet (NaN, stamped when the next update runs), and the two
        commands before it zero, as ros2_controllers' reset_buffers."""
        self.command_linear = self.command_angular = math.nan
        self.command_stamp_ns = -1  # set to the first update's time
        self.references[:] = math.nan
        self.last = [0.0, 0.0]  # linear, angular of the last command
        self.before_last = [0.0, 0.0]
        self.publisher.reset()  # the first update publishes
        self.warned_ns = {"timeout": -_THROTTLE_NS}

    def start(self) -> None:
        self.reset_buffers()

    def stop(self) -> None:
        """Deactivated: the wheels are commanded to stop (ros2_controllers' halt)."""
        self._write_wheels(0.0, 0.0)
        self.reset_buffers()

    def safe_stop(self) -> bool:
        self._write_wheels(0.0, 0.0)
        return True

    def cleanup(self) -> None:
        self.reset()

    # -- the loop ------------------------------------------------------------
    def update(self) -> None:
        now = self.stamp_ns
        if self.command_stamp_ns < 0:
            self.command_stamp_ns = now
        if not self.in_chained_mode:  # ros2_controllers' update_reference_from_subscribers
            self._receive(now)
            self._update_reference(now)
        linear, angular = float(self.references[0]), float(self.references[1])
        if not (math.isfinite(linear) and math.isfinite(angular)):
            return  # no command yet: the wheels keep what the hardware had
        dt = self.period
        last, before = self.last, self.before_last
        linear = self.linear_limiter.limit(linear, last[0], before[0], dt)
        angular = self.angular_limiter.limit(angular, last[1], before[1], dt)
        before[0], before[1] = last[0], last[1]
        last[0], last[1] = linear, angular

        time = self.time
        if self.open_loop:
            self.odometry.update_open_loop(linear, angular, time)
        elif not self._update_odometry(time, dt):
            return  # no feedback yet: ros2_controllers writes no command then either
        self.publisher.publish_due(now)
        if self.cmd_vel_out is not None:
            out = self.twist_message()
            self.stamp_to(out.header.stamp)
            out.twist.linear.x, out.twist.angular.z = linear, angular
            self.cmd_vel_out.write(out)
        half_turn = angular * self.separation / 2.0
        self._write_wheels(
            (linear - half_turn) / self.left_radius, (linear + half_turn) / self.right_radius
        )

    def _receive(self, now: int) -> None:
        """A new ~/cmd_vel is taken if younger than cmd_vel_timeout (a zero stamp is
        now); an older one is ignored with a warning."""
        if not self.cmd_vel.has_new_data:
            return
        message = self.cmd_vel.read()
        if message is None:
            return
        stamp = message.header.stamp
        stamp_ns = stamp.sec * _NS + stamp.nanosec
        if stamp_ns == 0:
            stamp_ns = now
        linear, angular = message.twist.linear.x, message.twist.angular.z
        if not (math.isfinite(linear) and math.isfinite(angular)):
            # ignored whole, its stamp too: a stream of them must not hold off the timeout
            self.refused_messages["~/cmd_vel"] += 1
            self.not_finite.warning(
                "~/cmd_vel ignored: %s is %r (not finite), %d refused so far; "
                "cmd_vel_timeout applies as if it had not arrived",
                "angular.z" if math.isfinite(linear) else "linear.x",
                angular if math.isfinite(linear) else linear,
                self.refused_messages["~/cmd_vel"])
            return
        if self.timeout_ns and now - stamp_ns >= self.timeout_ns:
            self.refused_messages["~/cmd_vel"] += 1
            self.log.warning(
                "ignoring a cmd_vel stamped %.3f s ago, older than cmd_vel_timeout %.3f s",
                (now - stamp_ns) / _NS, self.timeout_ns / _NS,
            )
            return
        self.command_linear = linear
        self.command_angular = angular
        self.command_stamp_ns = stamp_ns

    def _update_reference(self, now: int) -> None:
        """What the wheels follow: the command, or zero once it is older than
        cmd_vel_timeout (braking); before the first command, nothing (NaN)."""
        if self.timeout_ns and now - self.command_stamp_ns > self.timeout_ns:
            self.references[:] = 0.0
            self._throttled("timeout", now, "velocity command timed out: braking")
        elif math.isfinite(self.command_linear):  # finite both, or NaN both (none yet)
            self.references[0] = self.command_linear
            self.references[1] = self.command_angular

    def _update_odometry(self, time: float, dt: float) -> bool:
        assert self.feedback is not None
        wheels = self.feedback.read()
        if wheels is None:
            return False
        n = self.wheels_per_side
        if len(wheels) != 2 * n:
            raise ValueError(
                f"{self.feedback.topic} has {len(wheels)} values; give {2 * n}, one per wheel "
                f"({', '.join(self.left_names + self.right_names)})"
            )
        left = float(wheels[0]) if n == 1 else float(wheels[:n].mean())
        right = float(wheels[n]) if n == 1 else float(wheels[n:].mean())
        if not (math.isfinite(left) and math.isfinite(right)):  # ros2_controllers: ERROR
            raise ValueError(f"{self.feedback.topic} holds a value that is not finite: {wheels}")
        if self.position_feedback:
            self.odometry.update(left, right, time)
        else:
            self.odometry.update_from_travel(
                left * self.left_radius * dt, right * self.right_radius * dt, time
            )
        return True

    def _write_wheels(self, left: float, right: float) -> None:
        n = self.wheels_per_side
        speeds = np.empty(2 * n)
        speeds[:n] = left
        speeds[n:] = right
        self.velocity_command.write(speeds)

    def _throttled(self, key: str, now: int, text: str) -> None:
        if now - self.warned_ns[key] >= _THROTTLE_NS:
            self.warned_ns[key] = now
            self.log.warning(text)
