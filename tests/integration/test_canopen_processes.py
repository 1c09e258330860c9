"""CiA 402 drives over CANopen in the loop (rtcf_canopen/Cia402System), against the
project's simulated drives in another process, on python-can's udp_multicast bus inside a
network namespace each test makes (``unshare --net``: lo up, a multicast route on lo;
never the machine's own interfaces). ``rtcf launch`` without ROS: a ramp controller bound
by key moves two drives to a goal; a drive that faults in the middle; a drive that stops
answering; a drive absent at start."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

from .._proc import (
    NETWORK_NAMESPACE,
    can_make_network_namespace,
    env_with,
    run_in_network_namespace,
)
from .conftest import FIXTURES

pytestmark = [
    pytest.mark.integration,
    pytest.mark.skipif(not can_make_network_namespace(), reason=f"needs {NETWORK_NAMESPACE}"),
]
pytest.importorskip("canopen")
pytest.importorskip("msgpack")

URDF = """<robot name="two_drives">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="joint1" type="revolute"><parent link="base"/><child link="l1"/>
    <limit lower="-3" upper="3" velocity="5" effort="10"/></joint>
  <joint name="joint2" type="revolute"><parent link="l1"/><child link="l2"/>
    <limit lower="-3" upper="3" velocity="5" effort="10"/></joint>
  <ros2_control name="drives" type="system">
    <hardware>
      <plugin>rtcf_canopen/Cia402System</plugin>
      <param name="interface">udp_multicast</param>
      <param name="channel">239.74.163.2</param>
      <param name="max_stale_cycles">{max_stale}</param>
    </hardware>
    <joint name="joint1">
      <param name="node_id">2</param>
      <command_interface name="position"/>
      <state_interface name="position"/><state_interface name="velocity"/>
    </joint>
    <joint name="joint2">
      <param name="node_id">{second}</param>
      <command_interface name="position"/>
      <state_interface name="position"/><state_interface name="velocity"/>
    </joint>
  </ros2_control>
</robot>
"""

LAUNCH = """<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="frequency" value="1000.0"/>
    <param name="mode" value="no_wait"/>
    <param name="robot_description_file" value="$(dirname)/robot.urdf"/>
  </node>
  <node pkg="rtcf" exec="rt_launcher" name="ramp" args="rtcf_canopen_components GoalRamp">
    <param name="goal" value="[0.5, -0.3]"/>
    <param name="duration" value="0.4"/>
  </node>
</launch>
"""


def _run(tmp_path: Path, sim_args: str, *, second: int = 3, max_stale: int = 100,
         duration: float = 1.5) -> tuple[int, str]:
    """The sims and ``rtcf launch`` in a network namespace of their own."""
    (tmp_path / "robot.urdf").write_text(URDF.format(second=second, max_stale=max_stale))
    (tmp_path / "run.launch.xml").write_text(LAUNCH)
    script = textwrap.dedent(f"""\
        {sys.executable} -m rtcf_canopen.sim_drive --priority 60 --duration {duration + 6} \\
            {sim_args} > {tmp_path}/sim.log 2>&1 &
        sleep 0.5
        set +e
        {sys.executable} -m rtcf launch {tmp_path}/run.launch.xml --duration {duration} --quiet
        echo "rtcf exited $?"
        kill %1
        wait
        cat {tmp_path}/sim.log
        """)
    out = run_in_network_namespace(script, env_with(FIXTURES))
    code = int(out.split("rtcf exited ")[1].split()[0])
    return code, out


def test_two_drives_move_to_a_goal(tmp_path: Path) -> None:
    code, out = _run(tmp_path, "--node-id 2 --node-id 3")
    assert code == 0, out
    assert "2 drive(s) in OPERATION ENABLED" in out
    assert "GoalRamp: final positions 0.5000 -0.3000" in out, out
    # both drives were brought back to a safe state at the end
    assert out.count("state SWITCH ON DISABLED") == 2, out
    assert "node 2: " in out and "stale cycles" in out


def test_a_drive_that_faults_in_the_middle(tmp_path: Path) -> None:
    code, out = _run(tmp_path, "--node-id 2 --node-id 3 --fault-after 0.6 --fault-code 0x7305")
    faults = [line for line in out.splitlines() if "is in FAULT" in line]
    assert faults, out
    assert "CANopen drive node" in faults[0] and "on bus udp_multicast:239.74.163.2" in faults[0]
    assert "error code 0x7305" in faults[0], faults[0]
    # the loop's policy: the hardware went through on_error, and the run went on
    assert "its read returned ERROR" in out, out
    assert code == 0, out


def test_a_drive_that_stops_answering(tmp_path: Path) -> None:
    # node 3 falls silent after 0.5 s; node 2 stays; 300 stale cycles make it an error
    script = (f"--node-id 2 & {sys.executable} -m rtcf_canopen.sim_drive --priority 60 "
              "--duration 8 --node-id 3 --silent-after 0.5")
    code, out = _run(tmp_path, script, max_stale=300)
    assert code == 0, out
    silent = [line for line in out.splitlines() if "has not answered SYNC for 10 cycles" in line]
    assert silent and "node 3" in silent[0], out
    assert "has not answered SYNC for 300 cycles" in out, out
    assert "its read returned ERROR" in out  # the loop went on: never blocked


def test_a_drive_absent_at_start_is_one_clear_line(tmp_path: Path) -> None:
    code, out = _run(tmp_path, "--node-id 2", second=9, duration=0.5)
    assert code != 0, out
    lines = [line for line in out.splitlines() if "node 9" in line]
    assert len(lines) == 1, out
    assert "CANopen drive node 9 (joint 'joint2') on bus udp_multicast:239.74.163.2 did not " \
           "answer" in lines[0]
    assert "check that it is powered" in lines[0]
