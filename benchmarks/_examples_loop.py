"""``ros_messages.py --examples``: the loop with every controller of the two examples
active, driven from ROS as MoveIt and teleop drive them (issue 32).

* **arm**: ``arm.launch ros2_controllers:=true`` (MuJoCo arm at 1 kHz,
  joint_trajectory_controller at 250 Hz following a goal of this process's
  ActionClient, with ``controller_state`` at 50 Hz and the action's feedback at 20 Hz;
  joint_state_broadcaster at 100 Hz in its LET lane);
* **diffbot**: ``diffbot.launch`` (MuJoCo base at 1 kHz, diff_drive_controller taking
  ``cmd_vel`` from this process at 20 Hz, ``odom`` and ``/tf`` at its publish_rate).

Each runs ``--duration`` s with ``--middleware ros2``, in alternating rounds; reported:
the iteration's calculation time p50 and p99 and each controller's, medians of the
rounds, and how many of the controllers' messages reached this process.
"""

from __future__ import annotations

import statistics
import sys
import time
from typing import Any

import _common as c

NAME = "ros_messages_examples"
LAUNCH = c.REPO / "src" / "rtcf_examples" / "launch"
EXAMPLES: dict[str, tuple[str, list[str]]] = {  # name -> launch file, its arguments
    "arm": ("arm.launch", ["ros2_controllers:=true"]),
    "diffbot": ("diffbot.launch", []),
}
ACTION = "/arm_controller/follow_joint_trajectory"
CMD_VEL = "/diffbot_base_controller/cmd_vel"
COUNTED = {"arm": ("/joint_states", "feedback"), "diffbot": ("/diffbot_base_controller/odom",
                                                             "/tf")}


class Driver(c.SpinningNode):
    """An rclpy node spinning in a thread of this process: a FollowJointTrajectory
    goal to the arm once its server is up (one a run, as long as the run), ``cmd_vel``
    at 20 Hz, and counts of what the controllers publish."""

    def __init__(self, duration: float) -> None:
        from control_msgs.action import FollowJointTrajectory
        from geometry_msgs.msg import TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.action import ActionClient
        from sensor_msgs.msg import JointState
        from tf2_msgs.msg import TFMessage

        super().__init__("ros_messages_examples")
        self.count: dict[str, int] = {}
        for topic, cls in ((COUNTED["arm"][0], JointState), (COUNTED["diffbot"][0], Odometry),
                           ("/tf", TFMessage)):
            self.count[topic] = 0
            self.node.create_subscription(cls, topic, self._counter(topic), 100, raw=True)
        self.count["feedback"] = 0
        self.client = ActionClient(self.node, FollowJointTrajectory, ACTION)
        self.goal = _goal(FollowJointTrajectory, duration)
        self.running: Any = None  # the future of our goal's acceptance
        self.cmd_vel = self.node.create_publisher(TwistStamped, CMD_VEL, 10)
        self.twist = TwistStamped()
        self.twist.twist.linear.x, self.twist.twist.angular.z = 0.3, 0.2
        self.node.create_timer(0.05, self._drive)
        self.start()

    def _counter(self, topic: str) -> Any:
        def count(_: bytes) -> None:
            self.count[topic] += 1

        return count

    def _feedback(self, _: Any) -> None:
        self.count["feedback"] += 1

    def _drive(self) -> None:
        self.cmd_vel.publish(self.twist)  # stamp 0: "now" to the controller
        running = self.running
        if running is not None and running.done() and not running.result().accepted:
            self.running = None  # refused while the controller was not active yet
        if self.running is None and self.client.server_is_ready():  # one goal a run
            self.running = self.client.send_goal_async(self.goal, self._feedback)

    def new_run(self) -> None:
        self.running = None


def _goal(action: Any, duration: float) -> Any:
    """Joints 1 to 3 swinging 0.4 rad and back every second, for the whole run."""
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = action.Goal()
    goal.trajectory.joint_names = ["joint1", "joint2", "joint3"]
    for k in range(1, int(duration) + 3):
        point = JointTrajectoryPoint(positions=[0.4 * (k % 2), -0.3 * (k % 2), 0.2 * (k % 2)])
        point.time_from_start.sec = k
        goal.trajectory.points.append(point)
    return goal


def run(args: Any) -> int:
    duration = args.duration or (2.0 if args.quick else 10.0)
    rounds = 1 if args.quick else args.rounds
    machine = c.machine_info()
    started = time.perf_counter()
    runs: dict[str, list[dict[str, Any]]] = {e: [] for e in EXAMPLES}
    driver = Driver(duration)
    try:
        with c.workdir() as work:
            wrapper = c.rt_wrapper(not args.no_rt_wrapper, work)
            for r in range(rounds):
                for example, (launch, launch_args) in EXAMPLES.items():
                    print(f"round {r + 1}/{rounds}: {example}, {duration:g} s ...",
                          file=sys.stderr)
                    driver.new_run()
                    before = dict(driver.count)
                    result = c.run_rtcf(LAUNCH / launch, duration,
                                        work / f"report-{r}-{example}", wrapper=wrapper,
                                        extra_args=[*launch_args, "--middleware", "ros2"],
                                        env={"PYTHONPATH": str(c.REPO / "src")})
                    t = result.timing
                    runs[example].append({
                        "iterations": t["iterations"],
                        "overruns": t["overruns"],
                        "calc_us": t["calc_us"],
                        "components_calc_us": {n: v["calc_us"]
                                               for n, v in t["components"].items()},
                        "received": {k: driver.count[k] - before[k]
                                     for k in COUNTED[example]},
                        "realtime": c.rt_conditions(result),
                    })
    finally:
        driver.close()
    elapsed = time.perf_counter() - started

    def median(values: list[float]) -> float:
        return statistics.median(values)

    summary: dict[str, Any] = {}
    rows = []
    for example, example_runs in runs.items():
        calc = {q: median([x["calc_us"][q] for x in example_runs]) for q in ("p50", "p99")}
        names = example_runs[0]["components_calc_us"]
        parts = {n: {q: median([x["components_calc_us"][n][q] for x in example_runs])
                     for q in ("p50", "p99")} for n in names}
        received = {k: sum(x["received"][k] for x in example_runs)
                    for k in COUNTED[example]}
        summary[example] = {"calc_us": calc, "components_calc_us": parts,
                            "received": received,
                            "iterations": sum(x["iterations"] for x in example_runs),
                            "overruns": sum(x["overruns"] for x in example_runs)}
        rows.append([f"**{example}**: the iteration", c.fmt(calc["p50"]), c.fmt(calc["p99"]),
                     f"{summary[example]['overruns']} overruns; received "
                     + ", ".join(f"{k} {v}" for k, v in received.items())])
        for name, q in parts.items():
            rows.append([name, c.fmt(q["p50"]), c.fmt(q["p99"]), ""])
    tab = c.table(["calculation", "p50 [µs]", "p99 [µs]", ""], rows)
    print(f"machine: {c.machine_line(machine)}")
    print(tab)
    print(f"total {elapsed:.0f} s")
    data = {"benchmark": NAME, "timestamp": c.now_iso(), "duration_s_per_run": duration,
            "rounds": rounds, "machine": machine, "load_avg_after": c.load_avg(),
            "summary": summary, "runs": runs, "elapsed_s": elapsed}
    c.write_results(NAME, data, args.quick)
    if not args.quick:
        body = [
            "The two examples with every controller of rtcf_controllers active, each "
            f"with `--middleware ros2` at 1 kHz for **{duration:g} s** per run, {rounds} "
            "rounds alternating, medians of the rounds' quantiles: `arm.launch "
            "ros2_controllers:=true` (joint_trajectory_controller at 250 Hz following a "
            "FollowJointTrajectory goal sent by the benchmark's ActionClient, "
            "controller_state at 50 Hz and feedback at 20 Hz; joint_state_broadcaster at "
            "100 Hz in its LET lane) and `diffbot.launch` (diff_drive_controller on "
            "`cmd_vel` at 20 Hz from the benchmark, `odom` and `/tf` at 50 Hz). "
            "Calculation time of the iteration and of each component (its update with "
            "its writes and taps; `@send`: a LET lane's hand-over).",
            tab,
        ]
        c.publish_section(NAME, body, machine, data["timestamp"])
    return 0
