"""The state of the running loop that components may read: iteration, time, rate."""

from __future__ import annotations


class LoopState:
    """What the loop tells components about the current iteration."""

    __slots__ = ("frequency", "iteration", "period_ns", "running", "stamp_ns", "time_ns")

    def __init__(self, frequency: float = 1.0) -> None:
        self.frequency = frequency
        self.period_ns = round(1e9 / frequency)
        self.iteration = -1  # -1 before the first iteration
        self.time_ns = 0  # scheduled start of the current iteration, since the loop started
        # the same instant in ROS time (ns since the epoch; /clock time under use_sim_time)
        self.stamp_ns = 0
        self.running = False
