"""An ``rt_runner``'s robot description, taken as ros2_control Jazzy's controller manager
takes it (``controller_manager.cpp``: ``init_robot_description_callback``).

Under another launcher (ros2 launch, a bringup's ``robot_state_publisher``) the runner
subscribes to ``robot_description``, relative, so ``<its namespace>/robot_description``
after its remaps: std_msgs/String, keep last 1, reliable, transient local, the QoS
robot_state_publisher publishes it with, so a description published before the runner
started still arrives. The first one that parses is kept; a later one is ignored with
a line, as Jazzy's controller manager ignores it once its hardware is loaded; one that
does not parse is reported (one line naming the topic and the line inside it) and the
runner waits for the next, as Jazzy falls back to waiting. A ``robot_description``
parameter of the runner itself is taken instead of the topic (Humble's and Iron's way,
deprecated there and gone in Jazzy; common in bringups).

The message is taken in the bridge's thread and parsed there, in the supervisor: the
loop never sees it. Before the first run, :meth:`DescriptionListener.settle` waits a
little for a description whose publisher the graph already shows; one that comes later
is taken all the same (and said to have come after the loop started).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from .._core._errors import Location, RtcfError
from .._core._robot_description import HardwareInfo
from .._launch._robot_descriptions import PARAM, RobotDescription, read

SETTLE_S = 5.0  # the longest a runner waits for a description that is being published


def description_qos() -> Any:
    """robot_state_publisher's and ros2_control's QoS for ``robot_description``."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


class DescriptionListener:
    """The runner's robot description: its parameter, or the first from its topic."""

    def __init__(self, node: Any, say: Callable[[str], None],
                 parameter: Any = None) -> None:
        self._node = node
        self._say = say
        self._lock = threading.Lock()
        self._arrived = threading.Event()
        self._description: RobotDescription | None = None
        self._loop_started = False
        self._subscription: Any = None
        name = node.get_fully_qualified_name()
        if isinstance(parameter, str) and parameter.strip():
            self._take(read(parameter, Location(f"{name}'s parameter {PARAM}"),
                            f"{name}'s parameter {PARAM}"))
            return
        from std_msgs.msg import String

        self._subscription = node.create_subscription(
            String, PARAM, self._on_message, description_qos())
        self.topic: str = self._subscription.topic_name
        say(f"subscribed to {self.topic} for the robot description")

    # -- what the runner holds --------------------------------------------------------
    @property
    def description(self) -> RobotDescription | None:
        return self._description

    @property
    def robot_description(self) -> str | None:
        """The description's text (xacro already run), or None before one arrived."""
        return None if self._description is None else self._description.text

    @property
    def hardware(self) -> list[HardwareInfo]:
        """One HardwareInfo per ``<ros2_control>`` tag of the description."""
        return [] if self._description is None else list(self._description.hardware)

    def settle(self, timeout_s: float = SETTLE_S, *, expected: bool = False) -> bool:
        """Before the worker starts: wait up to ``timeout_s`` for the description if the
        graph shows a publisher of its topic, or if one is ``expected`` (a ros2_control
        bringup: discovery of a publisher started with the runner takes seconds). Whether
        there is one now."""
        if self._subscription is not None and not self._arrived.is_set():
            if expected or self._node.count_publishers(self.topic) > 0:
                deadline = time.monotonic() + timeout_s
                while not self._arrived.wait(0.05) and time.monotonic() < deadline:
                    pass
        with self._lock:
            self._loop_started = True
        return self._arrived.is_set()

    # -- the bridge's thread ----------------------------------------------------------
    def _on_message(self, msg: Any) -> None:
        if self._arrived.is_set():
            self._say(f"a robot description on {self.topic} again: ignored, the first one "
                      "is kept (as ros2_control keeps its loaded hardware)")
            return
        origin = f"topic {self.topic}"
        publishers = [f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                      for i in self._node.get_publishers_info_by_topic(self.topic)
                      if "_UNKNOWN_" not in i.node_name]  # not discovered yet: unnamed
        if len(publishers) == 1:
            origin += f" (published by {publishers[0]})"
        try:
            described = read(str(msg.data), Location(self.topic), origin)
        except RtcfError as exc:
            self._say(f"error: the robot description on {self.topic} is refused, waiting for "
                      f"another: {exc}")
            return
        self._take(described)

    def _take(self, described: RobotDescription) -> None:
        with self._lock:
            self._description = described
            late = (" (after the loop started: its hardware is not loaded; start the "
                    "runner after the description is published, or give it as the runner's "
                    "parameter robot_description)") if self._loop_started else ""
        self._arrived.set()
        self._say(described.summary() + late)

    def close(self) -> None:
        if self._subscription is not None:
            self._node.destroy_subscription(self._subscription)
            self._subscription = None
