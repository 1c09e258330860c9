"""The cascade at three rates (rtcf_examples cascade.launch, .launch.xml) under --sim:
iteration by iteration, which components ran and what every input saw, checked
against a plain-Python model of the same cascade with the schedule written out."""

from __future__ import annotations

import csv
import io
import math

import pytest

from rtcf.testing import run_launch

from .conftest import run_rtcf

pytestmark = pytest.mark.integration

FILES = ["cascade.launch", "cascade.launch.xml"]
N = 400  # ten hyperperiods of 40 iterations at 2 kHz: 200 ms


def _reference(n: int) -> dict[str, list[float | None]]:
    """The cascade by hand: motor and velocity loop every iteration, the position loop
    in iterations 1, 5, 9, ... (every 4, phase 1) and the supervisor in 0, 40, 80, ...
    (every 40, phase 0), in the order motor, supervisor, position, velocity."""
    period_ns = 500_000
    w = angle = 0.0
    torque: float | None = None
    setpoint: float | None = None
    error_seen: float | None = None
    velocity_setpoint: float | None = None
    pos_integral = vel_integral = 0.0
    pos_prev: float | None = None
    vel_prev: float | None = None
    out: dict[str, list[float | None]] = {
        k: []
        for k in ("position", "velocity", "position_setpoint", "tracking_error",
                  "velocity_setpoint", "torque")
    }

    def pid(sp, meas, kp, ki, limit, integral, prev, dt):
        error = (sp or 0.0) - (meas or 0.0)
        derivative = 0.0 if prev is None else (error - prev) / dt
        candidate = integral + error * dt
        u = kp * error + ki * candidate + 0.0 * derivative
        if -limit <= u <= limit:
            integral = candidate
        else:
            u = math.copysign(limit, u)
        return u, integral, error

    for i in range(n):
        dt = period_ns * 1 * 1e-9
        w += dt * ((torque or 0.0) - 0.05 * w) / 0.01
        angle += dt * w
        if i % 40 == 0:
            t = i * period_ns * 1e-9
            setpoint = 1.0 if int(t / 0.5) % 2 == 0 else 0.0
            error_seen = setpoint - angle
        if i % 4 == 1:
            velocity_setpoint, pos_integral, pos_prev = pid(
                setpoint, angle, 20.0, 0.0, 10.0, pos_integral, pos_prev, period_ns * 4 * 1e-9
            )
        torque, vel_integral, vel_prev = pid(
            velocity_setpoint, w, 0.5, 5.0, 2.0, vel_integral, vel_prev, dt
        )
        for key, value in (("position", angle), ("velocity", w), ("position_setpoint", setpoint),
                           ("tracking_error", error_seen),
                           ("velocity_setpoint", velocity_setpoint), ("torque", torque)):
            out[key].append(value)
    return out


@pytest.mark.parametrize("file", FILES)
def test_each_component_runs_in_its_iterations_and_inputs_see_the_right_values(file):
    trace = run_launch(f"rtcf_examples {file}", N)
    ran = trace.ran
    assert ran["/cascade/motor"] == list(range(N))
    assert ran["/cascade/velocity_controller"] == list(range(N))
    assert ran["/cascade/position_controller"] == list(range(1, N, 4))
    assert ran["/cascade/supervisor"] == list(range(0, N, 40))
    expected = _reference(N)
    for key, values in expected.items():
        assert trace.outputs[f"/cascade/{key}"] == values, key
    # a fast reader of a slow output: the value, and the iteration it was written in
    pid = trace.components["/cascade/velocity_controller"]
    assert pid.setpoint.iteration == max(i for i in range(1, N, 4))
    assert trace.outputs["/cascade/velocity_setpoint"][N - 1] == pid.setpoint.read()


def test_both_launch_formats_give_the_same_trace():
    a, b = (run_launch(f"rtcf_examples {f}", N) for f in FILES)
    assert a.outputs == b.outputs and a.ran == b.ran


def test_the_same_file_gives_identical_traces_under_sim_run_after_run(tmp_path):
    csvs = []
    for k in range(2):
        path = tmp_path / f"trace{k}.csv"
        result = run_rtcf(
            "launch", "rtcf_examples", "cascade.launch", "--sim", "--duration", "0.2",
            "--trace", str(path),
        )
        assert result.returncode == 0, result.stderr
        csvs.append(path.read_text())
    assert csvs[0] == csvs[1]
    rows = list(csv.DictReader(io.StringIO(csvs[0])))
    assert len(rows) == N
    expected = _reference(N)
    assert [float(r["/cascade/position"]) for r in rows] == expected["position"]


def test_the_plan_is_printed_with_each_phases_cost():
    result = run_rtcf("check", "rtcf_examples", "cascade.launch")
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "the schedule repeats every 40 iterations (20 ms)" in out
    assert "/cascade/position_controller  .x...x...x" in out
    assert "worst first: 10 in 1 phase (0); 8 in 10 phases (1, 5, 9, 13, ...)" in out


def test_a_rate_that_does_not_divide_is_one_clear_line():
    result = run_rtcf(
        "launch", "rtcf_examples", "cascade.launch", "position_rate:=300", "--sim",
        "--duration", "0.01",
    )
    assert result.returncode == 1
    assert (
        "component '/cascade/position_controller': rate 300 Hz does not divide the runner's "
        "frequency 2000 Hz; the nearest rates that do are 333.333 Hz (every:=6) or "
        "285.714 Hz (every:=7)"
    ) in result.stderr
    assert "cascade.launch" in result.stderr
