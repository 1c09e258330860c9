"""Faults with real processes: the rtcf command, its worker, signals and SIGKILL.

Each test checks the exit status, the one-line error, the safe_stop hook's side effect
(SafeHardware writes "0" to a file) and that no shared memory is left behind.
"""

import json
import os
import signal
import time

import pytest

from .._launches import launcher_xml
from .._proc import read_rest, rtcf_shm_names, wait_for, wait_for_match
from .test_worker import alive, runner_xml, start, write_launch

pytestmark = pytest.mark.integration

LOOP = """
  <node name="hw" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components SafeHardware -f">
    <param name="path" value="{path}"/>
  </node>
  <node name="ctrl" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components Faulty">
    <param name="at" value="{at}"/>
    <param name="what" value="{what}"/>{policy}
  </node>"""


def loop(tmp_path, at=20, what="error", policy="", runner=None, extra=""):
    marker = tmp_path / "torque"
    marker.write_text("1")
    body = LOOP.format(path=marker, at=at, what=what, policy=policy) + extra
    return write_launch(tmp_path, body, runner=runner), marker


def finish(proc, timeout=60):
    out, err = read_rest(proc, timeout)
    assert rtcf_shm_names() == []
    return out, err


def test_a_component_that_raises_stops_the_loop_through_safe_stop(tmp_path):
    path, marker = loop(tmp_path, at=20)
    proc = start("launch", path, "--duration", "5")
    _out, err = finish(proc)
    assert proc.returncode == 1, err
    errors = [line for line in err.splitlines() if line.startswith("rtcf: error:")]
    assert errors == [
        next(line for line in errors if "update() raised ZeroDivisionError: boom at iteration 20"
             in line)
    ], err
    assert marker.read_text() == "0"  # the hardware interface's safe_stop ran
    assert "/hw: safe_stop() ran" in err


@pytest.mark.parametrize(
    ("what", "named"), [("exit", "SystemExit: 3"), ("interrupt", "KeyboardInterrupt")]
)
def test_system_exit_and_keyboard_interrupt_in_update_are_named(tmp_path, what, named):
    path, marker = loop(tmp_path, at=10, what=what, policy='\n    <param name="on_error" '
                        'value="deactivate"/>')
    proc = start("launch", path, "--duration", "5")
    _out, err = finish(proc)
    assert proc.returncode == 1, err
    assert f"component '/ctrl': update() raised {named} at iteration 10" in err
    assert "Traceback" not in err
    assert marker.read_text() == "0"


def test_deactivate_contains_a_leaf_and_the_rest_goes_on(tmp_path):
    leaf = launcher_xml("display", "rtcf_fault_components Leaf", at=5, on_error="deactivate")
    path, marker = loop(tmp_path, at=-1, extra=leaf)
    report = tmp_path / "report"
    proc = start("launch", path, "--duration", "0.5", "--report", report)
    out, err = finish(proc)
    assert proc.returncode == 0, err
    assert "fault: component '/display': update() raised RuntimeError: display lost at " \
           "iteration 5; took out of the schedule: /display" in err
    assert "ran 100 iterations" in out
    assert marker.read_text() == "1"  # nobody else was safe-stopped
    doc = json.loads((report / "timing.json").read_text())
    assert [(f["component"], f["action"]) for f in doc["faults"]] == [
        ("/display", "deactivated")
    ]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_to_the_supervisor_runs_the_safe_stops(tmp_path, sig):
    path, marker = loop(tmp_path, at=-1)
    proc = start("launch", path)
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.3)
    proc.send_signal(sig)
    _out, err = finish(proc)
    assert marker.read_text() == "0", err
    assert "stopped abnormally; safe stops: /hw: safe_stop() ran" in err


def test_a_worker_whose_supervisor_is_killed_runs_its_safe_stops(tmp_path):
    path, marker = loop(tmp_path, at=-1)
    proc = start("launch", path)
    worker = int(wait_for_match(proc, r"loop in worker process (\d+)").group(1))
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.3)
    proc.kill()
    proc.wait()
    deadline = time.monotonic() + 20
    while alive(worker) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(worker)
    assert marker.read_text() == "0"
    proc.communicate()
    assert rtcf_shm_names() == []


SLOW_CONFIGURE = """
  <node name="driver" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components SlowConfigure"/>"""


def _blocked_in_configure(tmp_path, hook_timeout):
    """A run a second into its driver's configure(), which blocks."""
    path = write_launch(tmp_path, SLOW_CONFIGURE, runner=runner_xml(hook_timeout=hook_timeout))
    proc = start("launch", path)
    time.sleep(1.0)
    return proc


def test_a_configure_that_blocks_is_named_after_hook_timeout(tmp_path):
    path = write_launch(tmp_path, SLOW_CONFIGURE, runner=runner_xml(hook_timeout=1.0))
    t0 = time.monotonic()
    proc = start("launch", path, "--duration", "1")
    _out, err = finish(proc)
    assert proc.returncode == 1, err
    assert time.monotonic() - t0 < 15
    assert (
        "component '/driver': configure() did not return within 1 s (hook_timeout); the "
        "worker process" in err
    ), err


def test_sigterm_while_configure_blocks_ends_the_run_within_the_limit(tmp_path):
    proc = _blocked_in_configure(tmp_path, hook_timeout=2.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _out, err = finish(proc)
    assert time.monotonic() - t0 < 10
    assert proc.returncode != 0
    assert "configure() did not return within 2 s" in err, err


def test_a_second_ctrl_c_kills_the_worker_at_once(tmp_path):
    proc = _blocked_in_configure(tmp_path, hook_timeout=60.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    _out, err = finish(proc)
    assert time.monotonic() - t0 < 10
    assert proc.returncode == 130, err
    assert "second SIGINT: killed the worker" in err, err


def test_watchdog_consecutive_overruns(tmp_path):
    body = """
  <node name="busy" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components Busy">
    <param name="ms" value="8.0"/>
  </node>"""
    path = write_launch(
        tmp_path, body, runner=runner_xml(frequency=200.0, max_consecutive_overruns=5)
    )
    proc = start("launch", path, "--duration", "5")
    _out, err = finish(proc)
    assert proc.returncode == 1, err
    assert "watchdog max_consecutive_overruns=5: 6 overruns in a row at iteration" in err, err
    assert "Busy safe_stop in" in err


def test_the_supervisor_names_the_component_running_when_the_worker_dies(tmp_path):
    body = launcher_xml("busy", "rtcf_fault_components Busy", ms=0.1, hang_at=30)
    path = write_launch(tmp_path, body, runner=runner_xml(frequency=100.0))
    proc = start("launch", path)
    worker = int(wait_for_match(proc, r"loop in worker process (\d+)").group(1))
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.5)
    os.kill(worker, signal.SIGKILL)
    _out, err = finish(proc)
    assert proc.returncode == 1
    assert "was killed by SIGKILL" in err and "while /busy's update() was running" in err, err


def test_a_fallback_takes_over_and_the_hardware_interface_goes_on(tmp_path):
    backup = """
  <node name="backup" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components Backup"/>"""
    policy = """
    <param name="on_error" value="deactivate"/>
    <param name="fallback" value="backup"/>"""
    path, marker = loop(tmp_path, at=10, policy=policy, extra=backup)
    proc = start("launch", path, "--duration", "0.5")
    out, err = finish(proc)
    assert proc.returncode == 0, err
    assert (
        "fault: component '/ctrl': update() raised ZeroDivisionError: boom at iteration 10; "
        "took out of the schedule: /ctrl; /backup took over its outputs (fallback)"
    ) in err
    assert "ran 100 iterations" in out
    assert marker.read_text() == "1"  # the hardware interface was never safe-stopped
    assert "order: /hw -> /ctrl -> /backup" in err


def test_a_worker_whose_supervisor_hangs_stops_through_its_safe_stops(tmp_path):
    path, marker = loop(tmp_path, at=-1, runner=runner_xml(heartbeat_timeout=0.5))
    proc = start("launch", path)
    worker = int(wait_for_match(proc, r"loop in worker process (\d+)").group(1))
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.3)
    proc.send_signal(signal.SIGSTOP)  # alive, but silent
    try:
        deadline = time.monotonic() + 20
        while marker.read_text() != "0" and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.read_text() == "0"
    finally:
        proc.send_signal(signal.SIGCONT)
    proc.send_signal(signal.SIGTERM)
    _out, err = finish(proc)
    assert "no sign of life from the supervisor for 0.5 s (heartbeat_timeout)" in err, err
    assert not alive(worker)
