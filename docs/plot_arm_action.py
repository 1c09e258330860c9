"""The arm on ros2_controllers' controllers, driven through the action, as a plot:
``python docs/plot_arm_action.py [OUT.png]`` (default docs/images/arm-action.png).

arm.launch with ``ros2_controllers:=true`` runs in-process on the simulated clock
(rtcf.testing): MuJoCo's arm, rtcf_controllers' joint_trajectory_controller and
joint_state_broadcaster. At 0.2 s a FollowJointTrajectory goal of three waypoints
(positions and velocities: cubic segments, as MoveIt sends them) reaches
``/arm_controller/follow_joint_trajectory``. Per joint the plot draws the goal's
waypoints, the controller's desired trajectory (``controller_state``'s reference) and
the positions MuJoCo measured, with the goal's acceptance, its feedback and its
SUCCEEDED result. Needs .venv-ros2 (control_msgs) and matplotlib;
tests/ros2/controllers/test_arm_action_plot.py runs it in CI.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from rtcf import GoalStatus
from rtcf.testing import Goal, Trace, run_launch

ACTION = "/arm_controller/follow_joint_trajectory"
JOINTS = ["joint1", "joint2", "joint3"]
HZ = 1000.0  # arm.launch's loop
SENT_AT = 200  # iteration: 0.2 s of holding where the arm starts
SECONDS = 2.8  # run for this long: the goal's 2 s, its 1 s of goal_time to spare at most
# waypoints: time_from_start [s], then the positions [rad] of joint1..3
WAYPOINTS = [(0.7, [0.8, -0.3, 1.2]), (1.4, [0.2, 0.5, 0.4]), (2.0, [-0.4, 0.1, 0.9])]


@dataclass
class ArmRun:
    """What the run gave, in seconds of the simulated clock and radians."""

    trace: Trace
    waypoint_t: np.ndarray  # (points,): when each waypoint is due
    waypoints: np.ndarray  # (points, joints)
    reference_t: np.ndarray  # controller_state's stamps
    reference: np.ndarray  # (samples, joints): its reference.positions
    measured_t: np.ndarray
    measured: np.ndarray  # (iterations, joints): /arm/position, MuJoCo's joints
    accepted_t: float
    feedback_t: np.ndarray
    end_t: float
    status: GoalStatus
    error_code: int


def goal() -> FollowJointTrajectory.Goal:
    """The goal: WAYPOINTS with velocities by central differences, zero at the end."""
    times = np.array([0.0] + [t for t, _ in WAYPOINTS])
    points = np.array([[0.0, 0.3, 0.6]] + [q for _, q in WAYPOINTS])  # from where it starts
    slopes = np.diff(points, axis=0) / np.diff(times)[:, None]
    velocities = [(slopes[k] + slopes[k + 1]) / 2 for k in range(len(WAYPOINTS) - 1)]
    velocities.append(np.zeros(len(JOINTS)))
    trajectory = JointTrajectory(joint_names=JOINTS)
    for (t, q), v in zip(WAYPOINTS, velocities, strict=True):
        trajectory.points.append(JointTrajectoryPoint(
            positions=q, velocities=v.tolist(),
            time_from_start=Duration(sec=int(t), nanosec=round(t % 1 * 1e9))))
    return FollowJointTrajectory.Goal(trajectory=trajectory)


def run() -> ArmRun:
    """arm.launch with ros2_controllers:=true, the goal sent at SENT_AT."""
    trace = run_launch("rtcf_examples arm.launch", round(SECONDS * HZ),
                       args={"ros2_controllers": "true"},
                       actions={ACTION: {SENT_AT: Goal(goal(), id=1)}})
    record = trace.actions[ACTION].goals[1]
    times = np.array(trace.times)
    accepted = record.states[0][0]  # its first state: accepted (or rejected)
    states, stamps = [], []
    for msg in trace.outputs["/arm_controller/controller_state"]:
        if msg is None:
            continue
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        if not stamps or stamp != stamps[-1]:  # each one published, once
            stamps.append(stamp)
            states.append(list(msg.reference.positions))
    return ArmRun(
        trace=trace,
        waypoint_t=times[accepted] + np.array([t for t, _ in WAYPOINTS]),
        waypoints=np.array([q for _, q in WAYPOINTS]),
        reference_t=np.array(stamps),
        reference=np.array(states),
        measured_t=times,
        measured=np.array([q.tolist() for q in trace.outputs["/arm/position"]]),
        accepted_t=float(times[accepted]),
        feedback_t=times[[i for i, _ in record.feedback]],
        end_t=float(times[record.states[-1][0]]),
        status=record.status,
        error_code=record.result.error_code,
    )


def plot(arm: ArmRun, out: Path) -> None:
    """One panel per joint: waypoints, desired and measured, the goal's events."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(JOINTS), 1, sharex=True, figsize=(9, 7.5))
    for k, (ax, joint) in enumerate(zip(axes, JOINTS, strict=True)):
        ax.plot(arm.reference_t, arm.reference[:, k], color="C0",
                label="desired: controller_state's reference")
        ax.plot(arm.measured_t, arm.measured[:, k], "--", color="C1",
                label="measured: /arm/position (MuJoCo)")
        ax.plot(arm.waypoint_t, arm.waypoints[:, k], "o", color="k", markersize=6,
                label="the goal's waypoints")
        ax.axvline(arm.accepted_t, color="C2", lw=1, label="goal accepted")
        ax.axvline(arm.end_t, color="C4", lw=1, label=f"result: {arm.status.name}")
        ax.plot(arm.feedback_t, np.zeros_like(arm.feedback_t), "|", color="0.5",
                markersize=8, transform=ax.get_xaxis_transform(), label="feedback (20 Hz)")
        ax.set_ylabel(f"{joint} [rad]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s] (simulated clock)")
    axes[0].set_title("FollowJointTrajectory on /arm_controller: arm.launch "
                      "ros2_controllers:=true", fontsize=11)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).parent / "images" / "arm-action.png"
    arm = run()
    plot(arm, out)
    print(f"plot_arm_action: {arm.status.name} at {arm.end_t:.3f} s; "
          f"{len(arm.feedback_t)} feedback; wrote {out}")
    return 0 if arm.status == GoalStatus.SUCCEEDED else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
