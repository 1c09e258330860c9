"""The messages joint_trajectory_controller sends: its state, the action's feedback and
results, built from the controller's arrays.

Built only when they go out (feedback at ``action_monitor_rate``, the state at
``state_publish_rate``, a result once per goal): each is a new message, as a port's
value must not change after it is written. The message classes come in from the
controller (imported in its ``configure``), so this module imports no ROS package.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

# control_msgs/action/FollowJointTrajectory's Result error codes
SUCCESSFUL = 0
INVALID_GOAL = -1
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5

PREEMPTED = "Current goal preempted by new incoming action."
STOPPED = "Current goal cancelled during deactivate transition."


class Messages:
    """Makes one controller's messages; ``types`` are FollowJointTrajectory,
    JointTrajectoryControllerState and JointTrajectoryPoint."""

    def __init__(self, joints: Sequence[str], action: Any, state: Any, point: Any) -> None:
        self.joints = list(joints)
        self._action, self._state, self._point = action, state, point

    def result(self, code: int, text: str = "") -> Any:
        return self._action.Result(error_code=code, error_string=text)

    def _point_of(self, rows: np.ndarray, *, velocity: bool = True,
                  acceleration: bool = True, effort: np.ndarray | None = None,
                  seconds: float = 0.0) -> Any:
        point = self._point(positions=rows[0].tolist())
        if velocity:
            point.velocities = rows[1].tolist()
        if acceleration:
            point.accelerations = rows[2].tolist()
        if effort is not None:
            point.effort = effort.tolist()
        whole = int(seconds // 1)
        point.time_from_start.sec = whole
        point.time_from_start.nanosec = round((seconds - whole) * 1e9) % 1_000_000_000
        return point

    def feedback(self, component: Any, desired: np.ndarray, actual: np.ndarray,
                 error: np.ndarray) -> Any:
        """``desired``, ``actual``, ``error``: 3 x joints (position, velocity,
        acceleration), as ros2_controllers fills them."""
        fb = self._action.Feedback(joint_names=self.joints)
        component.stamp_to(fb.header.stamp)
        fb.desired = self._point_of(desired)
        fb.actual = self._point_of(actual)
        fb.error = self._point_of(error)
        return fb

    def state(self, component: Any, desired: np.ndarray, actual: np.ndarray,
              error: np.ndarray, output: Any, *, has_velocity: bool,
              has_acceleration: bool, since: float) -> Any:
        """``~/controller_state``: reference, feedback (what the state interfaces give),
        error, and output (what was commanded: ``output`` is
        ``(positions, velocities, accelerations, effort)``, None where not commanded)."""
        msg = self._state(joint_names=self.joints, speed_scaling_factor=1.0)
        component.stamp_to(msg.header.stamp)
        msg.reference = self._point_of(desired, seconds=since)
        msg.feedback = self._point_of(actual, velocity=has_velocity,
                                      acceleration=has_acceleration, seconds=since)
        msg.error = self._point_of(error, velocity=has_velocity,
                                   acceleration=has_acceleration)
        out = self._point()
        for field, values in zip(("positions", "velocities", "accelerations", "effort"), output,
                                 strict=True):
            if values is not None:
                setattr(out, field, values.tolist())
        msg.output = out
        return msg
