"""rtcf_canopen's example bringup (two_drives_bringup.launch.xml) under ROS 2, against two
simulated CiA 402 drives: a FollowJointTrajectory goal, sent as MoveIt does, moves both.

The whole scenario runs in one network namespace (``unshare --net``, lo up with a
multicast route): the drives (``rtcf_canopen.sim_drive``) and rtcf_canopen/Cia402System
talk over python-can's udp_multicast on a channel of this test's own, and DDS between
``rtcf launch`` and the client (fixtures/canopen_goal.py, rclpy's ActionClient) stays
there too: Fast DDS's default transports (shared memory and UDPv4) work on lo alone.
The client prints one JSON line: the result, /joint_states before and after, the states
seen. The run ends with SIGTERM, as a service manager stops it: both drives are brought
back to SWITCH ON DISABLED.

Without root the test fails (not skips) with one line saying why: CI runs it as root.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import pytest
from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory

from ..._proc import NETWORK_NAMESPACE, can_make_network_namespace, run_in_network_namespace
from ..conftest import rtcf_env

pytestmark = pytest.mark.integration

CLIENT = Path(__file__).parent / "fixtures" / "canopen_goal.py"
CHANNEL = "239.74.163.41"  # the test's own multicast group (the sims' default is .2)
GOAL = {"joint2": -0.4, "joint1": 0.6}  # not in the description's order
OPERATION_ENABLED, SWITCH_ON_DISABLED = 4, "SWITCH ON DISABLED"


def _scenario(tmp_path: Path) -> tuple[dict, str, str, str]:
    """The drives, the bringup and the client in a namespace: (the client's JSON line,
    the script's output, rtcf's output, the drives')."""
    py = shlex.quote(sys.executable)
    script = f"""
        {py} -m rtcf_canopen.sim_drive --node-id 2 --node-id 3 --priority 60 \\
            --channel {CHANNEL} --duration 60 > {tmp_path}/sim.log 2>&1 &
        sim=$!
        for _ in $(seq 100); do  # the drives listen: then the bringup configures them
            grep -q "sim_drive: node(s)" {tmp_path}/sim.log && break; sleep 0.1
        done
        {py} -m rtcf launch rtcf_canopen two_drives_bringup.launch.xml \\
            interface:=udp_multicast channel:={CHANNEL} --middleware ros2 \\
            > {tmp_path}/rtcf.log 2>&1 &
        rtcf=$!
        set +e
        {py} {CLIENT} {shlex.quote(json.dumps(GOAL))}
        echo "client exited $?"
        kill $rtcf; wait $rtcf
        echo "rtcf exited $?"
        kill $sim; wait $sim
        """
    out = run_in_network_namespace(script, rtcf_env(), timeout=90)
    rtcf, sim = ((tmp_path / f"{name}.log").read_text() for name in ("rtcf", "sim"))
    lines = [line for line in out.splitlines() if line.startswith("{")]
    assert len(lines) == 1 and "client exited 0" in out, f"{out}\n{rtcf}\n{sim}"
    return json.loads(lines[0]), out, rtcf, sim


def test_a_trajectory_goal_moves_both_simulated_drives(tmp_path: Path) -> None:
    if not can_make_network_namespace():
        pytest.fail(f"test_canopen_bringup: needs {NETWORK_NAMESPACE}: run the ROS 2 suite "
                    "as root, as CI does")
    seen, out, rtcf, sim = _scenario(tmp_path)
    everything = f"{seen}\n{out}\n{rtcf}\n{sim}"
    assert "hardware drives (system, rtcf_canopen/Cia402System: 2 joints)" in rtcf
    assert f"2 CiA 402 drive(s) on udp_multicast:{CHANNEL}" in rtcf, everything
    assert seen["accepted"] and seen["status"] == GoalStatus.STATUS_SUCCEEDED, everything
    assert seen["error_code"] == FollowJointTrajectory.Result.SUCCESSFUL, everything
    # from where the simulated drives start, through the trajectory, to the goal
    assert [seen["start"][j] for j in GOAL] == pytest.approx([0.0, 0.0], abs=0.01)
    assert [seen["final"][j] for j in GOAL] == pytest.approx(list(GOAL.values()), abs=0.02)
    halfway = [p for _, *p in seen["path"] if all(0.25 < p[i] / g < 0.75
                                                  for i, g in enumerate(GOAL.values()))]
    assert halfway, everything  # both drives between start and goal at once: no jump
    assert 0.9 < seen["done"] - seen["sent"] < 3.0, everything  # the 1 s trajectory
    assert seen["cia402_state"] == {"joint1": OPERATION_ENABLED, "joint2": OPERATION_ENABLED}
    # the run ended cleanly: the drives quick-stopped and back to SWITCH ON DISABLED
    assert "rtcf exited 0" in out, everything
    assert "Successful 'deactivate' of hardware 'drives'" in rtcf, everything
    assert "Traceback" not in rtcf + sim, everything
    last = sim.strip().splitlines()[-2:]
    assert [line.split(":")[1].strip() for line in last] == ["node 2", "node 3"], sim
    assert all(line.endswith(f"state {SWITCH_ON_DISABLED}") for line in last), sim
