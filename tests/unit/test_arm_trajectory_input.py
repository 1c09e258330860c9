"""rtcf_examples' TrajectoryInterpolator (the arm example's own trajectory input, with
~accept_trajectories): a trajectory with a position that is not finite or a negative
time is ignored, naming point and joint, and the plan goes on. trajectory_msgs faked."""

from __future__ import annotations

import logging
import math
import sys
import types
from types import SimpleNamespace as NS

import numpy as np
import pytest

import rtcf
from rtcf.testing import SILENCE, run_components
from rtcf_examples import TrajectoryInterpolator


@pytest.fixture(autouse=True)
def fake_trajectory_msgs(monkeypatch: pytest.MonkeyPatch) -> None:
    module = types.ModuleType("trajectory_msgs.msg")
    module.JointTrajectory = NS  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "trajectory_msgs", types.ModuleType("trajectory_msgs"))
    monkeypatch.setitem(sys.modules, "trajectory_msgs.msg", module)


def _trajectory(*points: tuple[float, list[float]]) -> NS:
    return NS(joint_names=["joint1", "joint2", "joint3"], points=[
        NS(time_from_start=NS(sec=math.floor(t), nanosec=round((t - math.floor(t)) * 1e9)),
           positions=p) for t, p in points])


@pytest.mark.parametrize(("bad", "why"), [
    (_trajectory((0.5, [0.1, math.nan, 0.0])), "point 0 position of joint2 is nan (not finite)"),
    (_trajectory((0.5, [0.1, 0.0, 0.0]), (1.0, [0.1, 0.0, -math.inf])),
     "point 1 position of joint3 is -inf (not finite)"),
    (_trajectory((-0.5, [0.1, 0.0, 0.0])), "point 0 time_from_start is -0.5 s (negative)"),
])
def test_a_bad_trajectory_is_ignored_naming_point_and_joint(
    bad: NS, why: str, caplog: pytest.LogCaptureFixture,
) -> None:
    spec = rtcf.ComponentSpec("trajectory", TrajectoryInterpolator, params={
        "waypoints": [0.0, 0.0, 0.0], "repeat": False, "accept_trajectories": True})
    with caplog.at_level(logging.ERROR):
        trace = run_components([spec], 100, frequency=100.0, inputs={
            "/position": np.zeros(3),
            "/joint_trajectory": lambda i, t: bad if i == 10 else SILENCE})
    assert all(np.isfinite(r).all() for r in trace.outputs["/position_reference"])
    assert trace.outputs["/position_reference"][-1].tolist() == [0.0, 0.0, 0.0]  # the plan
    assert [r.getMessage() for r in caplog.records] == [
        f"joint_trajectory ignored: {why}; the plan goes on"]
    assert trace.components["/trajectory"].refused_messages == {"joint_trajectory": 1}
