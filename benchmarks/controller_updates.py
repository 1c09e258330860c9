"""What one ``update()`` of each rtcf_controllers controller costs, publishing every time.

Each controller runs a few iterations in this process (``rtcf.testing``, simulated
clock, no middleware) with its inputs fed, its publication rates set to the loop's (so
that every update writes its messages: joint_state_broadcaster's ``/joint_states`` and
``dynamic_joint_states``, pid_controller's and the JTC's ``controller_state``, the
JTC's action feedback of a running goal, diff_drive's ``odom`` and ``/tf``); then its
``update()`` is called back to back, the taps of its outputs taken off (what is timed
is the controller and its writes, not the trace). Reported: the median per call, best
of ``--rounds`` rounds, in microseconds (docs/controllers.md#what-a-controller-costs-in-the-loop).

    .venv-ros2/bin/python benchmarks/controller_updates.py [--calls N] [--rounds N]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rtcf import ComponentSpec
from rtcf.testing import Goal, run_components

FREQUENCY = 1000.0
JOINTS = [f"joint{k + 1}" for k in range(7)]


def _arrays(n: int, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    return {name: np.linspace(0.1, 0.7, n) + k for k, name in enumerate(names)}


def _jsb(dynamic: bool) -> tuple[ComponentSpec, dict[str, Any], dict[str, Any]]:
    from rtcf_controllers import JointStateBroadcaster

    spec = ComponentSpec("jsb", JointStateBroadcaster,
                         params={"joints": JOINTS, "publish_dynamic_joint_states": dynamic})
    inputs = {f"/{k}": v for k, v in _arrays(7, ("position", "velocity", "effort")).items()}
    return spec, inputs, {}


def _pid(n: int) -> tuple[ComponentSpec, dict[str, Any], dict[str, Any]]:
    from control_msgs.msg import MultiDOFCommand

    from rtcf_controllers import PidController

    dofs = JOINTS[:n]
    params: dict[str, Any] = {"dof_names": dofs, "command_interface": "effort",
                              "reference_and_state_interfaces": ["position", "velocity"]}
    for dof in dofs:
        params[f"gains.{dof}.p"], params[f"gains.{dof}.d"] = 10.0, 1.0
    reference = MultiDOFCommand(dof_names=dofs, values=[1.0] * n, values_dot=[0.0] * n)
    inputs: dict[str, Any] = {f"/{k}": v for k, v in _arrays(n, ("position", "velocity")).items()}
    inputs["/pid/reference"] = reference
    return ComponentSpec("pid", PidController, params=params), inputs, {}


def _diff_drive() -> tuple[ComponentSpec, dict[str, Any], dict[str, Any]]:
    from geometry_msgs.msg import TwistStamped

    from rtcf_controllers import DiffDriveController

    params = {"left_wheel_names": ["left"], "right_wheel_names": ["right"],
              "wheel_separation": 0.4, "wheel_radius": 0.1, "publish_rate": FREQUENCY}
    cmd = TwistStamped()
    cmd.twist.linear.x, cmd.twist.angular.z = 0.5, 0.2
    inputs = {"/diff/cmd_vel": cmd, "/position": lambda k, t: np.array([t, 1.1 * t])}
    return ComponentSpec("diff", DiffDriveController, params=params), inputs, {}


def _jtc() -> tuple[ComponentSpec, dict[str, Any], dict[str, Any]]:
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint

    from rtcf_controllers import JointTrajectoryController

    params = {"joints": JOINTS, "command_interfaces": ["position"],
              "state_interfaces": ["position", "velocity"],
              "state_publish_rate": FREQUENCY, "action_monitor_rate": FREQUENCY}
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = JOINTS
    point = JointTrajectoryPoint(positions=[1.0] * 7)
    point.time_from_start.sec = 1000  # still running while it is timed
    goal.trajectory.points = [point]
    inputs = {f"/{k}": v for k, v in _arrays(7, ("position", "velocity")).items()}
    actions = {"/jtc/follow_joint_trajectory": {0: Goal(goal, id=1)}}
    return ComponentSpec("jtc", JointTrajectoryController, params=params), inputs, actions


CASES: dict[str, Callable[[], tuple[ComponentSpec, dict[str, Any], dict[str, Any]]]] = {
    "joint_state_broadcaster, 7 joints": lambda: _jsb(False),
    "joint_state_broadcaster, 7 joints, dynamic_joint_states": lambda: _jsb(True),
    "pid_controller, 1 dof": lambda: _pid(1),
    "pid_controller, 7 dofs": lambda: _pid(7),
    "diff_drive_controller, odom and /tf (the publication alone)": _diff_drive,
    "joint_trajectory_controller, 7 joints, state and feedback": _jtc,
}


def measure(case: str, calls: int, rounds: int) -> float:
    """Median µs per update(), best of ``rounds``."""
    spec, inputs, actions = CASES[case]()
    trace = run_components([spec], 20, frequency=FREQUENCY, inputs=inputs, actions=actions)
    comp = trace.components[spec.full_name]
    for port in comp._rtcf_outputs.values():
        port._tap = None
    for server in comp._rtcf_actions.values():
        server._events._tap = None
    # diff_drive publishes at publish_rate of the iterations' time, which calls outside
    # the loop do not advance: its publication is timed alone
    publisher = getattr(comp, "publisher", comp)  # its OdometryPublisher
    update = publisher._publish if "diff_drive" in case else comp.update
    best = float("inf")
    for _ in range(rounds):
        times = []
        for _ in range(calls):
            t0 = time.perf_counter_ns()
            update()
            times.append(time.perf_counter_ns() - t0)
        best = min(best, statistics.median(times) / 1000)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--case", action="append", help="only these (by the start of the name)")
    args = ap.parse_args()
    for case in CASES:
        if args.case and not any(case.startswith(c) for c in args.case):
            continue
        print(f"{measure(case, args.calls, args.rounds):7.1f} µs  {case}", flush=True)


if __name__ == "__main__":
    main()
