"""What DDS itself says about a mapped input with a deadline: its publishers matched
and lost, their liveliness, a QoS deadline missed, a QoS they do not offer.

The loop's own deadline (rtcf._core._deadlines) is the authority: it is exact, on the
loop's clock, and works with any publisher. This is the middleware's view beside it,
for the supervisor's log and /diagnostics: rclpy's subscription event callbacks
(``SubscriptionEventCallbacks``). With the runner's ``ros_qos_deadline`` the
subscription also requests the input's deadline as its QoS ``deadline`` and
liveliness lease (AUTOMATIC), so that DDS reports a silent or lost publisher within
that time; a publisher must then offer as much (a deadline and a lease no longer),
else DDS does not connect it: a default publisher (infinite deadline and lease) is
refused, and ``incompatible_qos`` says so. Without it the subscription's QoS is the
runner's, which every publisher matches, and a lost publisher is reported when
discovery notices it (the participant's lease: 20 s with Fast DDS' defaults).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from .._core._log import LogRecord

WARNING, INFO = 30, 20


def input_qos(base: Any, deadline: float, request: bool) -> Any:
    """The QoS of a mapped input: ``base``, with ``deadline`` requested as its QoS
    deadline and liveliness lease when ``request`` (and the input has one)."""
    if not request or deadline <= 0:
        return base
    from rclpy.duration import Duration
    from rclpy.qos import LivelinessPolicy, QoSProfile

    return QoSProfile(
        depth=base.depth,
        history=base.history,
        reliability=base.reliability,
        durability=base.durability,
        deadline=Duration(nanoseconds=round(deadline * 1e9)),
        liveliness=LivelinessPolicy.AUTOMATIC,
        liveliness_lease_duration=Duration(nanoseconds=round(deadline * 1e9)),
    )


class InputEvents:
    """Per mapped input with a deadline, what DDS reported: counted for /diagnostics,
    and said once per change in the log (from rclpy's executor thread)."""

    def __init__(
        self, node: Any, log: Callable[[LogRecord], None] | None = None
    ) -> None:
        self._node = node
        self.log = log
        self._lock = threading.Lock()
        # per topic: deadlines missed, liveliness lost, publishers now, incompatible QoS
        self.counts: dict[str, dict[str, int]] = {}

    def callbacks(self, topic: str) -> Any:
        """The event callbacks of ``topic``'s subscription."""
        from rclpy.event_handler import SubscriptionEventCallbacks

        with self._lock:
            self.counts[topic] = {
                "deadline_missed": 0, "liveliness_lost": 0, "publishers": 0,
                "incompatible_qos": 0,
            }

        def deadline(event: Any) -> None:
            first = self._count(topic, "deadline_missed", event.total_count_change)
            if first:  # once per silence: a missed deadline repeats every period
                self._say(WARNING, topic, "QoS deadline missed")

        def liveliness(event: Any) -> None:
            if event.not_alive_count_change > 0:
                self._count(topic, "liveliness_lost", event.not_alive_count_change)
                self._say(WARNING, topic, f"liveliness lost ({event.alive_count} alive)")
            elif event.alive_count_change > 0:
                self._unsay(topic)  # a new silence may be said again
                self._say(INFO, topic, f"liveliness back ({event.alive_count} alive)")

        def matched(event: Any) -> None:
            with self._lock:
                self.counts[topic]["publishers"] = event.current_count
            if event.current_count_change < 0:
                self._say(WARNING, topic, "a publisher was lost")
            elif event.current_count_change > 0:
                self._unsay(topic)  # a new silence may be said again
                self._say(INFO, topic, "a publisher matched")

        def incompatible(event: Any) -> None:
            self._count(topic, "incompatible_qos", event.total_count_change)
            policy = str(event.last_policy_kind).rpartition("_")[2].lower()
            self._say(
                WARNING, topic,
                f"a publisher offers an incompatible QoS ({policy}): DDS does not connect "
                "it; it must offer the input's deadline as its QoS deadline and lease "
                "(or leave the runner's ros_qos_deadline off)",
            )

        return SubscriptionEventCallbacks(
            deadline=deadline, liveliness=liveliness, matched=matched,
            incompatible_qos=incompatible,
        )

    def summary(self) -> dict[str, dict[str, int]]:
        with self._lock:
            return {
                t: {k: v for k, v in c.items() if not k.startswith("_")}
                for t, c in self.counts.items()
            }

    def _count(self, topic: str, what: str, change: int) -> bool:
        """Count ``change`` more of ``what``; True if the first ``what`` since messages
        came (each kind its own: a lost liveliness, which DDS reports at the same time
        as a missed deadline and in either order, does not silence the deadline)."""
        with self._lock:
            counts = self.counts[topic]
            counts[what] += max(0, change)
            first = not counts.get("_said_" + what, 0)
            counts["_said_" + what] = 1
        return first

    def _unsay(self, topic: str) -> None:
        with self._lock:
            counts = self.counts[topic]
            for key in [k for k in counts if k.startswith("_said_")]:
                counts[key] = 0

    def _say(self, level: int, topic: str, what: str) -> None:
        if self.log is None:
            return
        try:
            publishers = self._node.count_publishers(topic)
        except Exception:  # the node may be going down
            publishers = -1
        self.log(LogRecord(
            level, "rt_runner", f"ROS 2 input {topic}: {what}; {publishers} publishers now"
        ))
