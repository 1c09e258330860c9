"""The diffbot written as a ros2_control bringup under rtcf launch. With its hardware as a
component (rtcf_examples diffbot_component_bringup.launch.xml: the runner given the
controllers YAML, one spawner node per controller): the same odometry as
diffbot.launch, whose controller is an rt_launcher's; a spawner's --inactive controller
loaded but not run; the command line on the simulated clock. From its robot description
(diffbot_bringup.launch.xml: robot_state_publisher's xacro, rtcf_examples/MujocoSystem
or the mock): the same drive as the component's. In-process but for the command-line
runs."""

import subprocess
import sys

import numpy as np

from rtcf.testing import run_launch

from ... import _proc
from ..conftest import rtcf_env

ODOM = "/diffbot_base_controller/odom"
DRIVE = {"drive": "true", "segments": "[0.4, 0.0, 0.5, 0.3, 0.8, 0.5]"}


def poses(trace):
    """The odometry's pose at each iteration (the message last published)."""
    return np.array([(m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.orientation.z)
                     for m in trace.outputs[ODOM] if m is not None])


def test_the_bringup_drives_as_diffbot_launch_does():
    bringup = run_launch("rtcf_examples diffbot_component_bringup.launch.xml", duration=1.0,
                         args=DRIVE)
    launchers = run_launch("rtcf_examples diffbot.launch", duration=1.0, args=DRIVE)
    odom = poses(bringup)
    assert len(odom) > 950 and odom[-1, 0] > 0.2 and odom[-1, 2] > 0.01  # it drove, and turned
    np.testing.assert_array_equal(odom, poses(launchers))
    np.testing.assert_array_equal(bringup.outputs["/diffbot/base_pose"],
                                  launchers.outputs["/diffbot/base_pose"])
    # the YAML's joint_state_broadcaster, spawned too: the wheels' state at 1 kHz
    states = bringup.outputs["/joint_states"]
    assert len(states) == 1000 and states[-1].name == ["left_wheel_joint", "right_wheel_joint"]
    assert states[-1].velocity[0] < states[-1].velocity[1]  # turning left: right wheel faster


def test_an_inactive_spawned_controller_is_loaded_but_does_not_run(tmp_path):
    shipped = (_proc.SRC / "rtcf_examples" / "launch"
               / "diffbot_component_bringup.launch.xml").read_text()
    path = tmp_path / "inactive.launch.xml"
    path.write_text(shipped.replace(
        'args="joint_state_broadcaster"', 'args="joint_state_broadcaster --inactive"').replace(
        "$(dirname)/..", str(_proc.SRC / "rtcf_examples")))
    trace = run_launch(str(path), 40)
    assert trace.ran["/joint_state_broadcaster"] == []  # loaded, never run
    assert trace.outputs["/joint_states"] == [None] * 40
    assert trace.ran["/diffbot_base_controller"] == list(range(40))


def test_rtcf_launch_runs_the_bringup_on_the_simulated_clock():
    result = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", "rtcf_examples",
         "diffbot_component_bringup.launch.xml", "--sim", "--duration", "0.2"],
        env=rtcf_env(), capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert "order: /diffbot -> /diffbot_base_controller -> /joint_state_broadcaster" \
        in result.stderr
    assert "ran 200 iterations at 1000 Hz" in result.stdout  # update_rate: the frequency


def test_the_description_bringup_drives_as_the_component_bringup_does():
    """MujocoSystem steps the same model in the hardware's place that MujocoDiffbot
    steps as a component: read first, the controllers, write last. The component runs
    first in the order and steps in its update, so the two differ by where the first
    step falls in the first iteration: the poses agree within a millimetre."""
    component = poses(run_launch("rtcf_examples diffbot_component_bringup.launch.xml",
                                 duration=1.0, args=DRIVE))
    described = run_launch("rtcf_examples diffbot_bringup.launch.xml", duration=1.0, args=DRIVE)
    odom = poses(described)
    assert len(odom) == len(component) and odom[-1, 0] > 0.2 and odom[-1, 2] > 0.01
    np.testing.assert_allclose(odom, component, atol=1e-3)
    assert described.ran["/diffbot_base_controller"] == list(range(1000))
    # the mock: its wheels turn exactly as commanded, so it goes a little further
    mock = poses(run_launch("rtcf_examples diffbot_bringup.launch.xml", duration=1.0,
                            args={**DRIVE, "use_mock_hardware": "true"}))
    assert odom[-1, 0] < mock[-1, 0] < 1.1 * odom[-1, 0]
    np.testing.assert_allclose(mock[-1, 2], odom[-1, 2], rtol=0.1)
