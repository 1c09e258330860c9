"""The probe of ros2_latency.py: publishes sequence numbers, times their return.

An rclpy node publishes ``std_msgs/Float64`` on the input topic at a mean rate, at
random intervals (``--dither``), each message's value the next sequence number (1, 2,
...), and subscribes to the output topic. The system under test makes its output the
sequence number once it has come through the whole chain (it publishes repeatedly,
at its loop rate); the first message carrying a number gives that number's
end-to-end latency: the time it arrived (read first thing in the subscription
callback) minus the time just before it was published, both on CLOCK_MONOTONIC.
Numbers the output never carried are lost (with the chain's latest-value semantics:
overtaken by a newer one, or dropped).

Phases: wait until the topics are matched (discovery), publish until the first
output comes back (the chain is primed), ``--warmup`` seconds whose numbers are
discarded, ``--duration`` seconds measured, then up to ``--drain`` seconds for the
last ones to return. Prints one JSON object on stdout; exits 1 with one line on
stderr if the system never answers.
"""

from __future__ import annotations

import argparse
import itertools
import json
import random
import sys
import time
from typing import Any

from _ros2_node import start_node


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--input", required=True, help="topic the probe publishes on")
    p.add_argument("--output", required=True, help="topic the probe listens to")
    p.add_argument("--rate", type=float, default=200.0, help="messages per second (mean)")
    p.add_argument(
        "--dither",
        type=float,
        default=0.5,
        help="each interval is 1/rate times a uniform random factor in [1-D, 1+D]",
    )
    p.add_argument("--duration", type=float, default=10.0, help="seconds measured")
    p.add_argument("--warmup", type=float, default=1.0, help="seconds before measuring")
    p.add_argument("--drain", type=float, default=1.0, help="seconds to wait for the last")
    p.add_argument("--timeout", type=float, default=30.0, help="seconds to wait for the system")
    args = p.parse_args()

    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from std_msgs.msg import Float64

    node = start_node("rtcf_latency_probe")
    now = time.monotonic_ns
    sent: dict[int, int] = {}  # sequence number -> send time [ns]
    arrived: dict[int, int] = {}  # sequence number -> first arrival [ns]
    state = {"seq": 0, "newest": 0, "outputs": 0, "stale": 0, "measuring": 0}
    every_arrival: list[int] = []  # of every output message while measuring [ns]

    def on_output(msg: Float64) -> None:
        t = now()
        state["outputs"] += 1
        if state["measuring"]:
            every_arrival.append(t)
        seq = int(msg.data)
        if seq > state["newest"]:
            state["newest"] = seq
            arrived[seq] = t
        elif seq < state["newest"]:
            state["stale"] += 1  # an older number after a newer one: reordered

    pub = node.create_publisher(Float64, args.input, 10)
    node.create_subscription(Float64, args.output, on_output, 10)
    msg = Float64()

    period_ns = 1e9 / args.rate
    timers: list[Any] = []

    def send() -> None:
        state["seq"] += 1
        msg.data = float(state["seq"])
        sent[state["seq"]] = now()
        pub.publish(msg)
        # random intervals: a fixed one would keep the same phase to a periodic system's
        # loop (5 ms is a whole number of 1 ms periods) and sample one wait only
        factor = random.uniform(1.0 - args.dither, 1.0 + args.dither)
        timers[0].timer_period_ns = int(period_ns * factor)

    executor = SingleThreadedExecutor()
    executor.add_node(node)

    def spin_until(done: Any, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not done():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.01)
        return True

    try:
        if not spin_until(
            lambda: pub.get_subscription_count() > 0 and node.count_publishers(args.output) > 0,
            args.timeout,
        ):
            print(
                f"probe: no subscriber on {args.input} or no publisher on {args.output} "
                f"after {args.timeout:g} s",
                file=sys.stderr,
            )
            return 1
        timer = node.create_timer(1.0 / args.rate, send)
        timers.append(timer)
        if not spin_until(lambda: bool(arrived), args.timeout):
            print(
                f"probe: nothing came back on {args.output} in {args.timeout:g} s", file=sys.stderr
            )
            return 1
        primed_at = state["seq"]
        spin_until(lambda: False, args.warmup)
        first = state["seq"] + 1
        outputs0 = state["outputs"]
        print("probe: measuring", file=sys.stderr, flush=True)
        t0 = now()
        state["measuring"] = 1
        spin_until(lambda: False, args.duration)
        state["measuring"] = 0
        last = state["seq"]
        measured_ns = now() - t0
        print("probe: measured", file=sys.stderr, flush=True)
        timer.cancel()
        spin_until(lambda: state["newest"] >= last, args.drain)
        outputs = state["outputs"] - outputs0
        # the system's topics in the ROS graph (rtcf: only what it maps), once the run
        # has given discovery time to see them all (at the start it may not have)
        prefix = args.input.rsplit("/", 1)[0] + "/"
        graph_topics = sorted(
            name for name, _ in node.get_topic_names_and_types() if name.startswith(prefix)
        )
    except (KeyboardInterrupt, ExternalShutdownException):
        return 130
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()

    seqs = range(first, last + 1)
    latency_us = [(arrived[s] - sent[s]) / 1e3 for s in seqs if s in arrived]
    # intervals between the arrivals of consecutive numbers that both came back
    arrival_us = [
        (arrived[s + 1] - arrived[s]) / 1e3 for s in seqs[:-1] if s in arrived and s + 1 in arrived
    ]
    send_us = [(sent[s + 1] - sent[s]) / 1e3 for s in seqs[:-1]]
    # delay variation: arrival interval minus send interval of consecutive numbers
    variation_us = [
        (arrived[s + 1] - arrived[s] - sent[s + 1] + sent[s]) / 1e3
        for s in seqs[:-1]
        if s in arrived and s + 1 in arrived
    ]
    # for each lost number: how soon after it the next one was sent (a latest-value
    # chain keeps only the newer one if both reach a stage within one of its periods)
    lost_gap_us = [
        (sent[s + 1] - sent[s]) / 1e3 for s in seqs if s not in arrived and s + 1 in sent
    ]
    # runs of consecutive lost numbers: (first, how many, latency of the next that came)
    bursts: list[tuple[int, int, float | None]] = []
    for s in seqs:
        if s in arrived:
            continue
        if bursts and bursts[-1][0] + bursts[-1][1] == s - first:
            bursts[-1] = (bursts[-1][0], bursts[-1][1] + 1, bursts[-1][2])
        else:
            bursts.append((s - first, 1, None))
    for i, (start, n, _) in enumerate(bursts):
        nxt = first + start + n
        if nxt in arrived:
            bursts[i] = (start, n, round((arrived[nxt] - sent[nxt]) / 1e3, 1))
    result = {
        "rate_hz": args.rate,
        "graph_topics": graph_topics,
        "primed_after_messages": primed_at,
        "sent": len(seqs),
        "received": len(latency_us),
        "lost": len(seqs) - len(latency_us),
        "stale_outputs": state["stale"],
        "outputs": outputs,
        "measured_s": measured_ns / 1e9,
        "latency_us": latency_us,
        "arrival_interval_us": arrival_us,
        "send_interval_us": send_us,
        "delay_variation_us": variation_us,
        # intervals between every two output messages in a row (a periodic system
        # publishes once per period: how far from it they arrive is what a subscriber
        # sees of its timing)
        "output_interval_us": [
            (b - a) / 1e3 for a, b in itertools.pairwise(every_arrival)
        ],
        "lost_next_sent_after_us": lost_gap_us,
        "lost_runs": [list(b) for b in bursts],
    }
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
