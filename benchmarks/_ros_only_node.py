"""One node of Fig. 1 the ROS-only way: an rclpy node in a process of its own.

It does what a stage of ``_latency_components.Stage`` does (publish the smallest of its
forward inputs; subscribe to the feedback topics and ignore their values), the way a
ROS 2 user writes it without rtcf: subscriptions keep the latest value of each input
and

* ``--mode timer``: a timer at the loop rate publishes the output (a periodic node,
  as each of Fig. 1's components runs at the loop rate), or
* ``--mode event``: every message on a forward input publishes the output at once (a
  subscription-driven chain, no timer).

Started by ``ros2_latency.py``, one process per node (as ``ros2 run`` would); it runs
until SIGINT or SIGTERM. It prints ``ready`` on stdout once its subscriptions and its
publisher exist.

    python benchmarks/_ros_only_node.py --name H1 --inputs /in --feedback /r1,/out \
        --output /h1 --rate 1000 --mode timer
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from _ros2_node import spin_until_stopped, start_node


def _topics(text: str) -> list[str]:
    return [t for t in text.split(",") if t]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--name", required=True)
    p.add_argument("--inputs", type=_topics, required=True, help="forward input topics, a,b")
    p.add_argument("--feedback", type=_topics, default=[], help="feedback topics, a,b")
    p.add_argument("--output", required=True)
    p.add_argument("--rate", type=float, required=True, help="timer rate [Hz] (mode timer)")
    p.add_argument("--mode", choices=["timer", "event"], default="timer")
    args = p.parse_args()

    from std_msgs.msg import Float64

    node = start_node(args.name)
    latest: dict[str, float] = {}
    pub = node.create_publisher(Float64, args.output, 10)
    out = Float64()

    def publish() -> None:
        if len(latest) == len(args.inputs):
            out.data = min(latest.values())
            pub.publish(out)

    def forward(topic: str) -> Any:
        if args.mode == "event":

            def on_message(msg: Float64) -> None:
                latest[topic] = msg.data
                publish()

        else:

            def on_message(msg: Float64) -> None:
                latest[topic] = msg.data

        return on_message

    def ignore(msg: Float64) -> None:
        pass

    for topic in args.inputs:
        node.create_subscription(Float64, topic, forward(topic), 10)
    for topic in args.feedback:
        node.create_subscription(Float64, topic, ignore, 10)
    if args.mode == "timer":
        node.create_timer(1.0 / args.rate, publish)

    spin_until_stopped(node, lambda: print("ready", flush=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
