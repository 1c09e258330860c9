"""joint_trajectory_controller's ``~/follow_joint_trajectory`` goals: the action's
requests (goals and cancels) decided, a newer goal preempting the running one, its
feedback at ``action_monitor_rate``, and its end with ros2_controllers' result codes and
texts.

The controller follows trajectories and checks tolerances; this module holds which goal
runs and what the action is told about it. It acts on the controller that holds it:
a goal's trajectory is followed, or the joints held, through the controller's methods.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import rtcf

from . import _jtc_messages as results
from ._jtc_messages import Messages
from ._tolerances import Tolerances, for_goal
from ._trajectory import Trajectory

if TYPE_CHECKING:
    from .joint_trajectory_controller import JointTrajectoryController


class Goals:
    """The goal the controller executes (``goal``, -1: none; at most one runs) and the
    tolerances in force (``tolerances``: the goal's, else the defaults)."""

    def __init__(self, controller: JointTrajectoryController, action: rtcf.ActionServer,
                 messages: Messages) -> None:
        self._controller = controller
        self.action = action
        self.messages = messages
        self.defaults: Tolerances = controller.cfg.defaults
        self.tolerances = self.defaults
        self.goal: int = -1
        self.goal_iteration = 0  # the iteration it was accepted in: feedback counts from it

    def reset(self) -> None:
        """No goal runs (the controller starts)."""
        self.goal = -1
        self.tolerances = self.defaults

    def stop(self) -> None:
        """The controller stops: a running goal is aborted, as ros2_controllers'
        on_deactivate does."""
        if self.goal >= 0:
            self.end(self.action.abort, results.INVALID_GOAL, results.STOPPED)

    def poll(self, t: float) -> None:
        """Decide the action's request of this iteration, if any (``t``: the time)."""
        request = self.action.request()
        if request is not None:
            self._decide(request, t)

    def _decide(self, request: rtcf.ActionRequest, t: float) -> None:
        action, controller = self.action, self._controller
        if request.kind == rtcf.ActionRequest.CANCEL:
            if request.goal_id != self.goal:
                action.reject_cancel(request)
                return
            action.accept_cancel(request)
            controller.log.info("goal %d canceled: holding position", self.goal)
            self.end(action.canceled, 0, "")  # an empty result
            controller.hold()
            return
        goal = request.goal
        problem = controller.follow(goal.trajectory, t)
        if problem is not None:
            controller.refused_messages["~/follow_joint_trajectory"] += 1
            controller.log.error("goal %d rejected: %s", request.goal_id, problem)
            action.reject(request)
            return
        action.accept(request, preempt=self.messages.result(
            results.INVALID_GOAL, results.PREEMPTED))
        if self.goal >= 0:
            controller.log.info("goal %d preempted by goal %d", self.goal, request.goal_id)
        self.goal = request.goal_id
        self.goal_iteration = controller.iteration
        self.tolerances, why = for_goal(self.defaults, goal, controller.joints)
        if why is not None:
            controller.log.error("goal %d runs on the default tolerances: %s", self.goal, why)
        controller.log.info("goal %d accepted: %d points", self.goal,
                            len(goal.trajectory.points))

    def monitor(self, path_joint: int, goal_joint: int, late: bool, timed_out: bool,
                before_last: bool, since: float, trajectory: Trajectory) -> None:
        """The running goal: feedback at action_monitor_rate, and its end."""
        goal, controller = self.goal, self._controller
        log = controller.log
        # counted in the controller's own runs (its `rate` may be below the loop's)
        runs = (controller.iteration - self.goal_iteration) // controller.every
        if controller.cfg.feedback.due(runs):
            self.action.publish_feedback(goal, self.messages.feedback(
                controller, controller.desired, controller.actual, controller.error))
        tolerances = self.tolerances
        if path_joint >= 0:
            why = controller.why(tolerances.path, path_joint)
            log.warning("goal %d aborted: path tolerance violated (%s)", goal, why)
            self.end(self.action.abort, results.PATH_TOLERANCE_VIOLATED,
                     "Aborted due to path tolerance violation")
            controller.hold()
        elif before_last:
            return
        elif goal_joint < 0:
            log.info("goal %d reached", goal)
            self.end(self.action.succeed, results.SUCCESSFUL, "Goal successfully reached!")
            controller.hold(trajectory)
        elif late:
            text = f"Aborted due to goal_time_tolerance exceeding by {since:f} seconds"
            log.warning("goal %d: %s (%s)", goal, text,
                        controller.why(tolerances.goal, goal_joint))
            self.end(self.action.abort, results.GOAL_TOLERANCE_VIOLATED, text)
            controller.hold()
        elif timed_out:
            log.warning("goal %d aborted: cmd_timeout %g s after its last point",
                        goal, controller.cfg.cmd_timeout)
            self.end(self.action.abort, results.GOAL_TOLERANCE_VIOLATED,
                     "Aborted due to command timeout")
            controller.hold()

    def end(self, verb: Any, code: int, text: str) -> None:
        """End the running goal with ``verb`` (the action's succeed, abort or canceled)
        and a result of ``code`` and ``text``; the default tolerances are back."""
        verb(self.goal, self.messages.result(code, text))
        self.goal = -1
        self.tolerances = self.defaults
