"""docs/plot_arm_action.py, the plot of docs/examples.md's arm driven through the action,
runs as the docs show it (into tmp_path): arm.launch with ros2_controllers:=true
in-process, a FollowJointTrajectory goal of three waypoints to SUCCEEDED. Its numbers
are checked here, so the plot cannot quietly show a goal that failed."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from rtcf import GoalStatus

SCRIPT = Path(__file__).parents[3] / "docs" / "plot_arm_action.py"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("plot_arm_action", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up there
    spec.loader.exec_module(module)
    return module


def test_the_arm_follows_the_goals_waypoints_to_success_and_the_plot_is_drawn(
    tmp_path: Path,
) -> None:
    script = _script()
    arm = script.run()
    assert arm.status == GoalStatus.SUCCEEDED and arm.error_code == 0  # SUCCESSFUL
    assert arm.accepted_t == pytest.approx(script.SENT_AT / script.HZ, abs=0.002)
    # feedback at action_monitor_rate (20 Hz) on the controller's 250 Hz grid (4 ms),
    # from acceptance to the end
    assert np.diff(arm.feedback_t) == pytest.approx(0.05, abs=0.004)
    assert arm.feedback_t[0] >= arm.accepted_t and arm.feedback_t[-1] <= arm.end_t
    # held where it starts before the goal; the desired trajectory passes through each
    # waypoint at its time (controller_state at 50 Hz, the waypoints on its grid)
    before = arm.measured_t < arm.accepted_t
    assert np.abs(arm.measured[before] - [0.0, 0.3, 0.6]).max() < 1e-3
    for t, q in zip(arm.waypoint_t, arm.waypoints, strict=True):
        k = int(np.argmin(np.abs(arm.reference_t - t)))
        assert arm.reference[k] == pytest.approx(q, abs=0.03)
    # MuJoCo's arm ends within the goal tolerance (0.02 rad), and tracked on the way
    assert arm.measured[-1] == pytest.approx(arm.waypoints[-1], abs=0.02)
    on_the_way = np.interp(arm.measured_t, arm.reference_t, arm.reference[:, 0])
    assert np.abs(on_the_way - arm.measured[:, 0]).max() < 0.1
    assert list(arm.trace.last("/joint_states").name) == script.JOINTS

    out = tmp_path / "arm-action.png"
    script.plot(arm, out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
