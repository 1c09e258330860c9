"""The iteration's absolute ROS time stamp (the original's getTime())."""

from __future__ import annotations

import itertools
import time
from types import SimpleNamespace

import rtcf
from rtcf.testing import run_components


class Stamper(rtcf.Component):
    def configure(self) -> None:
        self.seen: list[tuple[int, int]] = []
        self.ros2 = SimpleNamespace(sec=0, nanosec=0)
        self.ros1 = SimpleNamespace(secs=0, nsecs=0)

    def update(self) -> None:
        self.seen.append((self.time_ns, self.stamp_ns))
        self.stamp_to(self.ros2)
        self.stamp_to(self.ros1)


def test_under_simulated_time_the_stamp_is_the_iterations_time() -> None:
    trace = run_components([Stamper], iterations=3, frequency=4.0)
    comp = trace.components["/Stamper"]
    assert comp.seen == [(0, 0), (250_000_000, 250_000_000), (500_000_000, 500_000_000)]
    assert (comp.ros2.sec, comp.ros2.nanosec) == (0, 500_000_000)
    assert (comp.ros1.secs, comp.ros1.nsecs) == (0, 500_000_000)


def test_on_the_system_clock_the_stamp_is_wall_time_on_the_iterations_grid() -> None:
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=1000.0))
    runner.load(rtcf.ComponentSpec("s", Stamper))
    before = time.time_ns()
    runner.run(5)
    after = time.time_ns()
    seen = runner.components["/s"].seen
    runner.shutdown()
    stamps = [stamp for _, stamp in seen]
    # wall time (not the monotonic clock's count since boot), within the run's span
    assert before - 10_000_000 <= stamps[0] and stamps[-1] <= after + 10_000_000
    # on the loop's grid: the stamps step exactly as the iterations' times do
    assert [b - a for a, b in itertools.pairwise(stamps)] == [1_000_000] * 4
    assert [s - t for t, s in seen] == [stamps[0] - seen[0][0]] * 5


def test_a_given_ros_offset_is_the_one_the_stamps_use() -> None:
    # a supervisor that stamps the run's records itself hands its offset to the loop
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=1000.0))
    runner.load(rtcf.ComponentSpec("s", Stamper))
    offset = 1_700_000_000_123_456_789
    before = time.monotonic_ns()
    runner.run(3, ros_offset_ns=offset)
    after = time.monotonic_ns()
    runner.run(2)  # the next run reads the clock's own again
    wall = time.time_ns()
    seen = runner.components["/s"].seen
    runner.shutdown()
    given = [stamp - offset for _, stamp in seen[:3]]  # the scheduled starts
    assert all(before - 10_000_000 <= t <= after for t in given), given
    assert all(abs(stamp - wall) < 50_000_000 for _, stamp in seen[3:])
