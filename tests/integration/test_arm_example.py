"""The arm example (rtcf_examples arm.launch, .launch.xml): a MuJoCo arm as the
hardware interface, a joint impedance controller at 1 kHz, a trajectory at 250 Hz and
HoldPosition as its fallback. Checked on the simulated clock: a step is followed
within bounds and the arm is held against gravity; both launch formats give the same
run; two recordings are identical and a changed gain shows in rtcf diff; a failing
trajectory is replaced and the arm held where it was; another driver slots in by the
hardware argument; a timestep that does not divide the period, and a missing mujoco,
each end in one line that says what to do."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import rtcf
from rtcf import ComponentSpec
from rtcf.testing import run_components, run_launch
from rtcf_examples import JointImpedance, MujocoArm

from .conftest import FIXTURES, run_rtcf

pytestmark = pytest.mark.integration

START = np.array([0.0, 0.3, 0.6])  # arm.launch's initial_positions


def _arm(**params):
    return ComponentSpec("hardware", MujocoArm, is_first=True,
                         params={"initial_positions": list(START), **params})


def test_a_step_is_followed_within_bounds_and_the_arm_is_held_against_gravity():
    goal = START + np.array([0.3, 0.3, -0.3])
    step_at = 200  # iterations at 1 kHz

    def reference(k, t):
        return START.copy() if k < step_at else goal.copy()

    trace = run_components(
        [_arm(), ComponentSpec("controller", JointImpedance,
                               params={"stiffness": 300.0, "damping": 30.0})],
        1200, frequency=1000.0, inputs={"/position_reference": reference},
    )
    q = np.array(trace.outputs["/position"])
    # before the step: still where it started, gravity compensated (it would sag by
    # gravity / stiffness, tens of mrad, without)
    assert np.abs(q[:step_at] - START).max() < 2e-3
    after = q[step_at:] - goal
    # the step: no more than 10 % overshoot, within 5 mrad after 600 ms, and it stays
    overshoot = np.max(np.sign(goal - START) * after, axis=0)  # past the goal
    assert np.all(overshoot < 0.1 * 0.3), overshoot
    assert np.abs(after[600:]).max() < 5e-3, np.abs(after[600:]).max(axis=0)


def test_without_gravity_compensation_the_arm_sags():
    """The test above can fail: the same controller without the gravity input sags."""
    trace = run_components(
        [_arm(), ComponentSpec("controller", JointImpedance, remaps=[("gravity", "unused")],
                               params={"stiffness": 300.0, "damping": 30.0})],
        500, frequency=1000.0, inputs={"/position_reference": START},
    )
    q = np.array(trace.outputs["/position"])
    assert np.abs(q[-1] - START).max() > 5e-3


@pytest.mark.parametrize("file", ["arm.launch", "arm.launch.xml"])
def test_the_trajectory_is_tracked_at_two_rates(file):
    trace = run_launch(f"rtcf_examples {file}", 3000)
    assert trace.ran["/arm/controller"] == list(range(3000))
    phase = trace.ran["/arm/trajectory"][0]  # the runner spreads the slow ones' phases
    assert trace.ran["/arm/trajectory"] == list(range(phase, 3000, 4))  # 250 Hz
    assert "/arm/hold" not in trace.ran or trace.ran["/arm/hold"] == []
    q = np.array(trace.outputs["/arm/position"])
    reference = trace.outputs["/arm/position_reference"]
    errors = [np.abs(a - r).max() for a, r in zip(q, reference, strict=True) if r is not None]
    assert len(errors) >= 2990 and max(errors) < 0.02, max(errors)
    # it went through the waypoints: at the end of each 1 s segment
    for k, waypoint in ((999, [0.8, 0.6, 0.9]), (1999, [-0.6, -0.4, 1.2]), (2999, START)):
        assert np.abs(q[k] - waypoint).max() < 1e-2, (k, q[k])


def test_both_launch_formats_give_the_same_run():
    a = run_launch("rtcf_examples arm.launch", 500)
    b = run_launch("rtcf_examples arm.launch.xml", 500)
    assert set(a.outputs) == set(b.outputs)
    for topic in a.outputs:
        for x, y in zip(a.outputs[topic], b.outputs[topic], strict=True):
            assert (x is None and y is None) or np.array_equal(x, y), topic


def test_two_recordings_are_identical_and_a_changed_gain_shows_in_rtcf_diff(tmp_path):
    paths = []
    for name, extra in (("a", []), ("b", []), ("c", ["stiffness:=400.0"])):
        path = tmp_path / f"{name}.mcap"
        done = run_rtcf("launch", "rtcf_examples", "arm.launch", *extra, "--sim",
                        "--duration", "1", "--record", path)
        assert done.returncode == 0, done.stderr
        paths.append(path)
    same = run_rtcf("diff", paths[0], paths[1])
    assert (same.returncode, same.stdout) == (0, "identical: 7 topics, 5500 messages\n")
    differ = run_rtcf("diff", paths[0], paths[2])
    assert differ.returncode == 1, differ.stdout
    assert "first difference: /arm/effort_command at iteration" in differ.stdout
    # the reference does not depend on the stiffness until the arm it starts from does
    assert "/arm/position " in differ.stdout or "/arm/position\n" in differ.stdout
    plot = run_rtcf("plot", paths[0], "/arm/position_reference", "/arm/position",
                    "--overlay", "-o", tmp_path / "arm.png")
    assert plot.returncode == 0, plot.stderr
    assert (tmp_path / "arm.png").stat().st_size > 10_000


def test_a_failing_trajectory_is_replaced_and_the_arm_held_where_it_was():
    trace = run_launch("rtcf_examples arm.launch", 2500, args={"fail_after_s": "1.5"})
    assert trace.ran["/arm/trajectory"][-1] < 1500
    held = trace.ran["/arm/hold"]
    assert held and 1500 <= held[0] < 1508  # at its next 250 Hz slot
    q = np.array(trace.outputs["/arm/position"])
    assert len(q) == 2499  # the failed iteration ended at the failure: no row
    # at 1.5 s the arm moved fast (mid-segment); held, it stops close by and stays
    moving = np.abs(q[1500] - q[1490]).max()
    assert moving > 5e-3
    assert np.abs(q[2000:] - q[2000]).max() < 1e-3  # still
    assert np.abs(q[2000] - q[1500]).max() < 0.1  # near where it was when it failed
    reference = trace.outputs["/arm/position_reference"]
    assert np.array_equal(reference[-1], reference[1600])  # one held reference


def test_a_safe_stop_leaves_the_arm_held_against_gravity_not_falling():
    """A fault stops the loop while the arm moves: MujocoArm's safe_stop turns its
    motors into position servos about where it is, with gravity held. Stepped on after
    the stop, the arm comes to rest there; with zero torque, as a naive driver would
    leave it, the arm falls."""
    import mujoco

    from rtcf_examples import TrajectoryInterpolator
    from rtcf_examples._arm import shipped_model

    arms = []

    class Arm(MujocoArm):
        def configure(self):
            super().configure()
            arms.append(self)

    with pytest.raises(rtcf.ComponentError, match=r"failing at t=0\.5"):
        run_components([
            ComponentSpec("hardware", Arm, is_first=True,
                          params={"initial_positions": list(START)}),
            ComponentSpec("controller", JointImpedance),
            ComponentSpec("trajectory", TrajectoryInterpolator, params={
                "waypoints": [0.5, 0.8, 0.4], "fail_after_s": 0.5}),
        ], 1000, frequency=1000.0)
    [arm] = arms
    stopped_at = arm.data.qpos.copy()
    assert np.abs(arm.data.qvel).max() > 0.1  # it was moving when the loop stopped
    naive = mujoco.MjModel.from_xml_path(shipped_model())  # motors at zero torque
    falling = mujoco.MjData(naive)
    falling.qpos[:], falling.qvel[:] = arm.data.qpos, arm.data.qvel
    for _ in range(1000):  # a second
        mujoco.mj_step(arm.model, arm.data)
        mujoco.mj_step(naive, falling)
    assert np.abs(arm.data.qpos - stopped_at).max() < 0.05  # held near where it stopped
    assert np.abs(arm.data.qvel).max() < 1e-3  # and still
    assert np.abs(falling.qpos - stopped_at).max() > 0.3  # fell


def test_another_driver_slots_in_by_the_hardware_argument(monkeypatch):
    monkeypatch.syspath_prepend(str(FIXTURES))
    trace = run_launch("rtcf_examples arm.launch", 2000,
                       args={"hardware_module": "rtcf_test_components",
                             "hardware": "IdealArm"})
    assert type(trace.components["/arm/hardware"]).__name__ == "IdealArm"
    q = np.array(trace.outputs["/arm/position"])
    assert np.abs(q[999] - [0.8, 0.6, 0.9]).max() < 0.02  # the same controllers track it


def test_a_timestep_that_does_not_divide_the_period_is_refused_in_one_line():
    done = run_rtcf("launch", "rtcf_examples", "arm.launch", "frequency:=300.0", "--sim",
                    "--duration", "0.1")
    assert done.returncode == 1
    said = [line for line in done.stderr.splitlines() if "timestep" in line]
    assert len(said) == 1, done.stderr
    assert "/arm/hardware" in said[0]
    assert "its timestep 1 ms does not divide this component's period 3.33333 ms" in said[0]
    assert "arm.launch" in said[0]


def test_a_slower_loop_takes_whole_steps():
    trace = run_components([_arm()], 10, frequency=500.0)
    assert trace.components["/hardware"].steps == 2


def test_without_mujoco_one_line_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco raises ImportError
    with pytest.raises(rtcf.RtcfError) as caught:
        run_components([_arm()], 1)
    assert "MujocoArm needs the mujoco package: pip install 'rtcf[mujoco]'" in str(caught.value)


def test_a_recording_is_drawn_into_frames_and_a_gif(tmp_path):
    recording = tmp_path / "arm.mcap"
    done = run_rtcf("launch", "rtcf_examples", "arm.launch", "--sim", "--duration", "1",
                    "--record", recording)
    assert done.returncode == 0, done.stderr
    from PIL import Image

    def render_arm(*args):  # as a user runs it: its own process picks the OpenGL (EGL)
        return subprocess.run([sys.executable, "-m", "rtcf_examples.render_arm", *args],
                              capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL)

    done = render_arm(str(recording), "--render", str(tmp_path / "frames"))
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"render_arm: wrote 15 frames and arm.gif to {tmp_path / 'frames'}\n"
    frames = sorted((tmp_path / "frames").glob("frame_*.png"))
    assert len(frames) == 15  # 0 to 0.999 s (the last iteration) at 15 frames per second
    images = []
    for path in (frames[0], frames[-1]):
        with Image.open(path) as image:
            images.append(np.asarray(image, dtype=float))
    first, last = images
    assert first.shape == (360, 480, 3)
    assert np.abs(first - last).mean() > 0.5  # the arm moved between them
    with Image.open(tmp_path / "frames" / "arm.gif") as gif:
        assert gif.n_frames == 15
    empty = render_arm(str(recording), "--render", str(tmp_path / "x"), "--topic", "/nothing")
    assert empty.returncode == 1
    assert empty.stderr == (f"render_arm: error: {recording} has no messages on /nothing; "
                            "record it with rtcf launch ... --record FILE.mcap\n")


# -- what reaches the hardware (docs/hardware-limits.md) ------------------------------
def test_a_nan_reference_never_reaches_the_motors_and_the_arm_holds_on():
    """The bug of issue 38 at the hardware's edge: a reference with a NaN (from a
    controller that passed one on) makes the impedance controller command NaN torques;
    MujocoArm is given the previous torques instead, MuJoCo stays stable and the arm
    follows the good references before and after."""
    goal = START + np.array([0.2, 0.0, 0.0])

    def reference(k, t):
        if 300 <= k < 310:
            return np.array([np.nan, 0.3, 0.6])
        return START.copy() if k < 300 else goal.copy()

    trace = run_components(
        [_arm(), ComponentSpec("controller", JointImpedance,
                               params={"stiffness": 300.0, "damping": 30.0})],
        1200, frequency=1000.0, inputs={"/position_reference": reference},
    )
    q = np.array(trace.outputs["/position"])
    assert np.isfinite(q).all()
    assert np.isfinite(np.array(trace.outputs["/effort"])).all()
    guard = trace.components["/hardware"]._rtcf_guards["effort_command"]
    assert guard.nan == 10  # each NaN torque command refused, the previous one held
    assert np.abs(q[-1] - goal).max() < 5e-3


def test_a_launch_file_narrows_the_motors_limits_and_the_run_reports_the_clamps(tmp_path):
    """joint_limits.joint2.max_effort in the launch file: the shoulder's torque is
    clamped to it (gravity needs more, so it sags), counted per joint, and said at the
    end of the run and in timing.json."""
    launch = tmp_path / "arm_limits.launch.xml"
    launch.write_text("""<launch>
  <node pkg="rtcf" exec="rt_runner" name="rt_runner">
    <param name="mode" value="no_wait"/>
    <param name="frequency" value="1000.0"/>
  </node>
  <group>
    <push-ros-namespace namespace="arm"/>
    <node pkg="rtcf" exec="rt_launcher" name="hardware" args="rtcf_examples MujocoArm">
      <param name="is_first" value="true"/>
      <param name="initial_positions" value="[0.0, 0.3, 0.6]"/>
      <param name="joint_limits.joint2.max_effort" value="2.0"/>
    </node>
    <node pkg="rtcf" exec="rt_launcher" name="controller" args="rtcf_examples JointImpedance"/>
  </group>
</launch>
""")
    report = tmp_path / "report"
    done = run_rtcf("launch", launch, "--sim", "--duration", "0.5", "--report", report)
    assert done.returncode == 0, done.stderr
    limits = json.loads((report / "timing.json").read_text())["command_limits"]
    effort = limits["/arm/hardware.effort_command"]
    assert effort["topic"] == "/arm/effort_command"
    assert effort["clamped"]["joint2"] > 400 and effort["clamped"]["joint1"] == 0
    assert effort["refused_not_a_number"] == effort["refused_infinite"] == 0
    assert ("limits: command input '/arm/hardware.effort_command' (/arm/effort_command, "
            "effort): clamped joint2") in done.stderr
    # said once a second, not every iteration
    assert done.stderr.count("effort command clamped to its limits (joint2 ") == 1
