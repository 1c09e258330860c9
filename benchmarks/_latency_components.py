"""The rtcf component of ros2_latency.py: one stage of Fig. 1 that carries a number through.

Every stage writes the smallest of its forward inputs, so R3's output equals the input
topic's sequence number once that number has come through every path of Fig. 1
(H1 -> F1 -> R2 -> R3 and H1 -> R1 -> R2). ``fb1``/``fb2`` are Fig. 1's loops back into
H1 (from R1 and R3): read every iteration, as the paper's H1 does, but not used, so
that the output stays a function of the input. ``_ros_only_node.py`` does the same in
an rclpy node.
"""

from __future__ import annotations

import rtcf


class Stage(rtcf.Component):
    """out = min(in1, in2, in3) over the inputs that have a value; written every iteration."""

    def configure(self) -> None:
        self.forward = [self.add_input(f"in{i}", float) for i in (1, 2, 3)]
        self.feedback = [self.add_input(f"fb{i}", float) for i in (1, 2)]
        self.out = self.add_output("out", float)

    def update(self) -> None:
        value = None
        for port in self.forward:
            v = port.read()
            if v is not None and (value is None or v < value):
                value = v
        for port in self.feedback:
            port.read()
        if value is not None:
            self.out.write(value)
