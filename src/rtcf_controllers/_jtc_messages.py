"""The messages joint_trajectory_controller sends: its state, the action's feedback and
results, built from the controller's arrays.

The state and the feedback have a shape fixed at configure time (the joints, the state
and command interfaces): each is an ``rtcf.Serialized`` laid out once, into which a
publication copies the controller's arrays (a point's positions, velocities and
accelerations lie a fixed stride apart in the bytes: one 3 x joints view each) and
which it writes again (in-process readers: docs/ros2.md "Writing messages in the
loop"). A result, once per goal, is a new rosidl message. The message classes come in
from the controller (imported in its ``configure``), so this module imports no ROS
package.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

import rtcf

from ._layouts import matrix

# control_msgs/action/FollowJointTrajectory's Result error codes
SUCCESSFUL = 0
INVALID_GOAL = -1
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5

PREEMPTED = "Current goal preempted by new incoming action."
STOPPED = "Current goal cancelled during deactivate transition."


ROWS = ("positions", "velocities", "accelerations")  # a point's rows, in its order
OUTPUT = {"position": "positions", "velocity": "velocities", "acceleration": "accelerations",
          "effort": "effort"}  # a command interface -> its field of the state's output


class Messages:
    """One controller's messages; ``action`` is FollowJointTrajectory, ``state``
    JointTrajectoryControllerState; ``has_velocity``, ``has_acceleration``: which
    state interfaces there are (feedback and error carry only those); ``commands``: the
    command interfaces (the output's fields)."""

    def __init__(self, joints: Sequence[str], action: Any, state: Any, *,
                 has_velocity: bool, has_acceleration: bool,
                 commands: Sequence[str]) -> None:
        self.joints = list(joints)
        self._action = action
        n = len(self.joints)
        measured = 1 + has_velocity + has_acceleration
        full = dict.fromkeys(ROWS, n)
        part = {r: n if k < measured else 0 for k, r in enumerate(ROWS)}
        self._state = rtcf.Serialized(
            state, joint_names=self.joints, speed_scaling_factor=1.0, reference=full,
            feedback=part, error=part, output={OUTPUT[c]: n for c in commands})
        self._state_points = [self._point(self._state, "reference", 3),
                              self._point(self._state, "feedback", measured),
                              self._point(self._state, "error", measured)]
        self._output = [(self._state.view(f"output.{OUTPUT[c]}"), f"{c}_command")
                        for c in commands]
        self._since = [self._state.stamp_setter(f"{p}.time_from_start")
                       for p in ("reference", "feedback")]
        self._feedback = rtcf.Serialized(action.Feedback, joint_names=self.joints,
                                         desired=full, actual=full, error=full)
        self._feedback_points = [self._point(self._feedback, p, 3)
                                 for p in ("desired", "actual", "error")]

    @staticmethod
    def _point(message: rtcf.Serialized, point: str, rows: int) -> np.ndarray:
        """A point's first ``rows`` rows (positions, ...) as one rows x joints view."""
        return matrix([message.view(f"{point}.{r}") for r in ROWS[:rows]])

    def result(self, code: int, text: str = "") -> Any:
        return self._action.Result(error_code=code, error_string=text)

    def feedback(self, component: Any, desired: np.ndarray, actual: np.ndarray,
                 error: np.ndarray) -> rtcf.Serialized:
        """``desired``, ``actual``, ``error``: 3 x joints (position, velocity,
        acceleration), as ros2_controllers fills them."""
        fb = self._feedback
        fb.stamp_ns = component.stamp_ns
        for view, values in zip(self._feedback_points, (desired, actual, error),
                                strict=True):
            view[:] = values
        return fb

    def state(self, component: Any, desired: np.ndarray, actual: np.ndarray,
              error: np.ndarray, written: Mapping[str, np.ndarray],
              since: float) -> rtcf.Serialized:
        """``~/controller_state``: reference, feedback (what the state interfaces give),
        error, and output (what was last commanded, ``written`` by port name)."""
        msg = self._state
        msg.stamp_ns = component.stamp_ns
        for view, values in zip(self._state_points, (desired, actual, error), strict=True):
            view[:] = values[: len(view)]
        since_ns = round(since * 1e9)
        for set_since in self._since:
            set_since(since_ns)
        for view, port in self._output:
            last = written.get(port)
            if last is not None:
                view[:] = last
        return msg
