"""The learned-policy example (rtcf_examples cartpole.launch) through ``rtcf launch``:
the policy in its LET lane (its own worker process) beside the 1 kHz loop.

Under ``--sim`` and in real time the recordings are the same, value for value, and in
both the PD stage acts on a release's action exactly 20 iterations after the state the
policy saw. A policy that goes quiet in real time leaves the PD stage in its safe
behaviour at the exact iteration, logged, and the run goes on; a policy lane killed
mid-run ends every lane through its safe stops, with one line naming the lane.
"""

from __future__ import annotations

import os
import re
import signal
import time

import numpy as np
import pytest

from .._proc import read_rest, rtcf_shm_names, wait_for_match
from .conftest import run_rtcf
from .test_lanes_processes import messages
from .test_worker import start

pytest.importorskip("mujoco")
pytest.importorskip("onnxruntime")

pytestmark = pytest.mark.integration

EXAMPLE = ("rtcf_examples", "cartpole.launch")
EVERY = 20
KP, KD, LIMIT, SCALE = 60.0, 12.0, 40.0, 0.5  # config/cartpole_policy.yaml, the launch file
# a run that was kept off its CPU: a value a lane kept from the window before, or a
# record the supervisor could not take in time (both counted and said): not comparable
TROUBLE = re.compile(r"\d+ (late|lost|let overruns|releases skipped)\b|dropped: [1-9]")


def record(tmp_path, name, *args):
    path = tmp_path / f"{name}.mcap"
    done = run_rtcf("launch", *EXAMPLE, "--duration", "1", "--record", path, *args)
    assert done.returncode == 0, done.stderr
    return path, done.stderr


def on_time_record(tmp_path, name, *args):
    """A real-time recording in which nothing was late, lost or dropped (at most three
    tries: on a loaded machine a lane may be kept off its CPU for periods)."""
    for _ in range(3):
        path, said = record(tmp_path, name, *args)
        if not TROUBLE.search(said):
            return path
    raise AssertionError(f"three runs with values late, lost or dropped:\n{said[-2000:]}")


def assert_lands_every_iterations_after_its_observation(path):
    """The PD stage's force at i is kp (target - x_i) - kd xdot_i with the action of
    release r = (i // 20 - 1) * 20 (release 0 saw no state yet), computed from the
    state iteration r - 1 left: as numpy computes it in JointPd, bit for bit."""
    import rtcf.recording

    rec = rtcf.recording.read(str(path))
    series = {t: rec.series(t) for t in ("/cartpole/position", "/cartpole/velocity",
                                         "/cartpole/observation", "/cartpole/target",
                                         "/cartpole/effort_command")}
    by_iteration = {t: dict(zip(s.iterations.tolist(), s.values, strict=True))
                    for t, s in series.items()}
    position, velocity = by_iteration["/cartpole/position"], by_iteration["/cartpole/velocity"]
    observation, target = by_iteration["/cartpole/observation"], by_iteration["/cartpole/target"]
    effort = by_iteration["/cartpole/effort_command"]
    assert sorted(target) == list(range(EVERY, 1000, EVERY))  # written at each release
    for r in target:
        assert observation[r][:2].tolist() == position[r - 1].astype(np.float32).tolist(), r
    for i in range(2 * EVERY, 1000):
        r = (i // EVERY - 1) * EVERY
        want = np.subtract(target[r][:1], position[i][:1])
        np.multiply(want, KP, out=want)
        want -= velocity[i][:1] * KD
        np.clip(want, -LIMIT, LIMIT, out=want)
        assert effort[i].tolist() == want.tolist(), i
    # one window earlier or later would not give these forces
    i = 4 * EVERY + 5
    for wrong in (i // EVERY - 2) * EVERY, (i // EVERY) * EVERY:
        assert (target[wrong] - position[i][0]) * KP - velocity[i][0] * KD != effort[i][0]
    assert {round(float(v[0]), 6) for v in target.values()} != {0.0}  # the policy acted


def test_the_sim_and_the_real_time_recordings_are_the_same_value_for_value(tmp_path):
    sim, _ = record(tmp_path, "sim", "--sim")
    real = on_time_record(tmp_path, "real")
    assert_lands_every_iterations_after_its_observation(sim)
    # (topic, iteration, value); the stamps differ: simulated time from 0, wall time
    reference, recorded = ([(t, i, data) for t, i, _, data in messages(path)]
                           for path in (sim, real))
    assert len(reference) == 3 * 1000 + 2 * 49  # 49 releases write
    assert {t for t, *_ in reference} == {
        "/cartpole/position", "/cartpole/velocity", "/cartpole/observation",
        "/cartpole/target", "/cartpole/effort_command"}
    assert recorded == reference


def test_a_policy_gone_quiet_in_real_time_leaves_the_pd_stage_holding_and_the_run_goes_on(
    tmp_path,
):
    # the last release that writes is 480 (before 0.5 s): its action arrives at 500,
    # the target's deadline (50 ms) passes at 551, the same in real time as under --sim
    path = tmp_path / "quiet.mcap"
    done = run_rtcf("launch", *EXAMPLE, "silent_after_s:=0.5", "push_at_s:=inf",
                    "--duration", "1", "--record", path, "--record-topics", "/cartpole/position")
    assert done.returncode == 0, done.stderr
    assert "ran 1000 iterations" in done.stdout, done.stdout
    said = [line for line in done.stderr.splitlines() if "target past its deadline" in line]
    assert len(said) == 1, done.stderr
    assert re.search(r"#551 \[/cartpole/pd\]: target past its deadline at iteration 551: "
                     r"holding at \[-?\d", said[0]), said[0]
    assert "passed its deadline of 0.05 s 1 time" in done.stderr, done.stderr
    assert "rtcf: error:" not in done.stderr and "safe stop" not in done.stderr
    # held: the cart stays where it was at 551 (left at zero force it drifts off)
    import rtcf.recording

    x = rtcf.recording.read(str(path)).series("/cartpole/position")
    held = x.values[x.iterations >= 551, 0]
    assert len(held) > 100 and np.abs(held - held[0]).max() < 0.02, held


def test_a_killed_policy_lane_ends_the_run_through_the_safe_stops_with_one_line(tmp_path):
    proc = start("launch", *EXAMPLE, "--duration", "30")
    found = wait_for_match(proc, r"policy \(LET, every 20; pid (\d+), ", 30)
    wait_for_match(proc, r"running 30000 iterations", 30)
    time.sleep(0.5)
    os.kill(int(found.group(1)), signal.SIGKILL)
    _out, err = read_rest(proc, 60)
    assert proc.returncode == 1, err
    errors = [line for line in err.splitlines() if line.startswith("rtcf: error:")]
    assert len(errors) == 1, err
    assert "lane 'policy'" in errors[0] and "killed by SIGKILL" in errors[0], errors[0]
    # the main lane's hardware interface stopped safely: it holds the cart
    assert re.search(r"\[/cartpole/hardware\]: safe stop: holding the cart at -?\d", err), err
    assert rtcf_shm_names() == []
