"""What one action feedback costs the supervisor's drain: decoded for rclpy, or as bytes.

In this process: the ROS 2 bridge's action server (``rtcf._ros2._actions``) on an rclpy
node, its two rings in local memory, and an rclpy ActionClient whose goal the "loop"
(this script, through the worker's ``EventTap``) accepts. Per round, 50 feedback
records are written into the events ring and one ``drain()`` publishes them; its time
over 50 is the cost per feedback. Two systems side by side, in alternating rounds: the
feedback's CDR published as it is through the server's own publisher
(``_feedback_bytes``, now), and deserialized into the Feedback message for rclpy's
``publish_feedback`` (before, and the fallback). Three feedback types: a 7-joint
``control_msgs`` FollowJointTrajectory (names, desired, actual, error: positions and
velocities), test_msgs' NestedMessage, a Fibonacci of 7 terms. Prints a table (quoted
in docs/ros2.md, "Actions"); writes nothing.

    .venv-ros2/bin/python benchmarks/action_feedback.py [--rounds N]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from test_msgs.action import Fibonacci, NestedMessage

from rtcf import ActionEvent
from rtcf._core._rings import Ring
from rtcf._ros2._actions import ActionBridge, _Served
from rtcf._runtime import _action_channels as ac

PER_DRAIN = 50  # feedback records per drain (the events ring holds 64)


def _feedbacks() -> dict[str, tuple[Any, Any]]:
    """name -> (action type, one feedback)."""
    out: dict[str, tuple[Any, Any]] = {}
    try:
        from control_msgs.action import FollowJointTrajectory
    except ImportError:  # built by scripts/setup-ros2; Python 3.11 only here
        pass
    else:
        fjt = FollowJointTrajectory.Feedback()
        fjt.joint_names = [f"joint{k}" for k in range(7)]
        for point in (fjt.desired, fjt.actual, fjt.error):
            point.positions = [0.1 * k for k in range(7)]
            point.velocities = [0.2 * k for k in range(7)]
        out["FollowJointTrajectory (7 joints)"] = (FollowJointTrajectory, fjt)
    out["NestedMessage"] = (NestedMessage, NestedMessage.Feedback())
    out["Fibonacci (7 terms)"] = (Fibonacci, Fibonacci.Feedback(sequence=list(range(7))))
    return out


def _ring(direction: str) -> Ring:
    records, size = ac.ring_shape(direction, 4096)
    return Ring.create(bytearray(Ring.nbytes(records, size)), records, size)


def measure(node: Any, executor: Any, action_type: Any, feedback: Any,
            rounds: int) -> dict[str, list[float]]:
    """µs per feedback of each drain, per system."""
    name = f"/bench/{action_type.__name__.lower()}"
    bridge = ActionBridge(node, executor, lambda component: True)
    served = _Served(node, action_type, name, "/bench", bridge)
    bridge._served[name] = served
    served.requests, served.events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    tap = ac.EventTap(served.events, ac.message_codecs(name, action_type), [0])
    as_bytes = served.feedback_bytes
    if as_bytes is None:
        raise SystemExit("the action server's feedback publisher was not found: no bytes path")
    client = ActionClient(node, action_type, name)
    client.wait_for_server(timeout_sec=10)
    future = client.send_goal_async(action_type.Goal(), feedback_callback=lambda m: None)
    while served.requests.pending()[1] == 0:
        executor.spin_once(timeout_sec=0.01)
    goal_id = next(iter(served.goals))
    tap(ActionEvent(ActionEvent.RESPONSE, goal_id, 2, None, 1))  # accepted
    while served.goals[goal_id].handle is None:
        bridge.drain()
        executor.spin_once(timeout_sec=0.01)
    times: dict[str, list[float]] = {"bytes": [], "decoded": []}
    event = ActionEvent(ActionEvent.FEEDBACK, goal_id, 2, feedback)
    for r in range(rounds * 2):
        system = ("bytes", "decoded")[r % 2]
        served.feedback_bytes = as_bytes if system == "bytes" else None
        for _ in range(PER_DRAIN):
            tap(event)
        t0 = time.perf_counter_ns()
        bridge.drain()
        times[system].append((time.perf_counter_ns() - t0) / PER_DRAIN / 1000)
        for _ in range(10):  # the client takes what it can (keep_last 10): not timed
            executor.spin_once(timeout_sec=0.001)
    del future
    bridge.close_run()
    client.destroy()
    bridge.shutdown()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=40)
    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node("action_feedback_benchmark")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    print(f"µs per feedback in one drain of {PER_DRAIN}, {args.rounds} rounds each, "
          "median (best)")
    print(f"{'feedback':34} {'as bytes (now)':>16} {'decoded (before)':>18} {'ratio':>7}")
    try:
        for label, (action_type, feedback) in _feedbacks().items():
            t = measure(node, executor, action_type, feedback, args.rounds)
            b, d = statistics.median(t["bytes"]), statistics.median(t["decoded"])
            print(f"{label:34} {b:9.1f} ({min(t['bytes']):4.1f}) "
                  f"{d:11.1f} ({min(t['decoded']):5.1f}) {d / b:6.1f}x")
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
