"""The loop in its own worker process: isolation, real-time settings, every way it ends.

Each test starts the real command line (a supervisor) which starts a real worker;
no shared memory may ever have a name in /dev/shm (it is anonymous: memfds).
"""

import json
import os
import pty
import re
import signal
import subprocess
import sys
import time

import pytest

from .._launches import runner_xml, write_launch
from .._proc import env_with, read_rest, rtcf_shm_names, start_rtcf, wait_for, wait_for_match
from .conftest import FIXTURES, run_rtcf

pytestmark = pytest.mark.integration


def bomb(at):
    """/bomb, raising in its update at iteration ``at`` (-1: never)."""
    return f"""
  <node name="bomb" pkg="rtcf" type="rt_launcher" args="rtcf_test_components Explodes">
    <param name="at" value="{at}"/>
  </node>"""


FACTS = """
  <node name="facts" pkg="rtcf" type="rt_launcher" args="rtcf_test_components WorkerFacts"/>"""


def env():
    return env_with(FIXTURES)


def start(*args, **kwargs):
    return start_rtcf(env(), *args, **kwargs)


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie of ours is gone for our purposes
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def wait_gone(pid, timeout=10.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not alive(pid):
            return True
        time.sleep(0.05)
    return False


def test_components_run_in_a_separate_single_threaded_worker(tmp_path):
    path = write_launch(tmp_path, FACTS)
    result = run_rtcf("launch", path, "--duration", "0.2")
    assert result.returncode == 0, result.stderr
    m = re.search(r"loop in worker process (\d+)", result.stderr)
    assert m, result.stderr
    worker = int(m.group(1))
    facts = re.search(
        r"facts pid=(\d+) threads=(\d+) tasks=(\d+) gc_enabled=(\w+) policy=(\d+) "
        r"middleware=(\S+)",
        result.stderr,
    )
    assert facts, result.stderr
    assert int(facts.group(1)) == worker  # update ran in the worker, not in the CLI
    assert facts.group(2) == "1" and facts.group(3) == "1"  # one thread, one kernel task
    assert facts.group(4) == "False"  # the garbage collector is off while running
    assert int(facts.group(5)) == os.SCHED_FIFO
    assert facts.group(6) == "none"
    # configure ran there too, and its non-real-time log line came through
    assert f"configured in process {worker}" in result.stderr
    assert wait_gone(worker)


def test_realtime_settings_are_applied_reported_and_written(tmp_path):
    runner = runner_xml(
        frequency=500.0,
        priority=70,
        cpu_affinity_mask=2 if os.cpu_count() > 1 else 1,
        lock_memory="true",
        safe_stack_size_kB=256,
        safe_heap_size_kB=1024,
    )
    path = write_launch(tmp_path, FACTS, runner=runner)
    result = run_rtcf("launch", path, "--duration", "0.5", "--report", tmp_path / "r")
    assert result.returncode == 0, result.stderr
    line = next(ln for ln in result.stderr.splitlines() if ln.startswith("rtcf: real-time:"))
    for part in ("SCHED_FIFO priority 70", "mlockall", "heap 1024 kB pre-faulted",
                 "stack 256 kB pre-faulted", "gc frozen", "kernel PREEMPT"):
        assert part in line, result.stderr
    assert "NOT applied" not in result.stderr
    doc = json.loads((tmp_path / "r" / "timing.json").read_text())
    rt = doc["realtime"]
    assert rt["scheduler"] == "SCHED_FIFO" and rt["priority"] == 70
    assert rt["mlockall"] is True
    assert rt["cpu_affinity"] == ([1] if os.cpu_count() > 1 else [0])
    assert rt["kernel_preemption"]
    assert doc["iterations"] == 250 and doc["log_records_dropped"] == 0
    assert doc["histograms_ns"]["calc"]["count"] == doc["samples"] == 250
    png = (tmp_path / "r" / "timing.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000


def test_refused_settings_are_reported_and_the_loop_still_runs(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("needs root to drop capabilities")
    path = write_launch(tmp_path, FACTS, runner=runner_xml(lock_memory="true"))

    def without_rt_privileges():
        # what a normal user has: no CAP_SYS_NICE, no CAP_IPC_LOCK, and low limits
        import ctypes
        import resource

        libc = ctypes.CDLL(None, use_errno=True)
        for cap in (14, 23):  # CAP_IPC_LOCK, CAP_SYS_NICE out of the bounding set
            assert libc.prctl(24, cap, 0, 0, 0) == 0  # PR_CAPBSET_DROP
        resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
        resource.setrlimit(resource.RLIMIT_MEMLOCK, (64 * 1024, 64 * 1024))

    result = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", str(path), "--duration", "0.2"],
        capture_output=True,
        text=True,
        env=env(),
        preexec_fn=without_rt_privileges,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    err = result.stderr
    assert re.search(r"warning: real-time: scheduler NOT applied: .*ulimit -r", err), err
    assert re.search(r"warning: real-time: mlockall NOT applied: .*ulimit -l", err)
    assert re.search(r"policy=0 ", result.stderr)  # it ran, with normal scheduling


def test_nothing_is_left_in_dev_shm_after_a_normal_run(tmp_path):
    proc = start("launch", write_launch(tmp_path, FACTS), "--duration", "0.3")
    _out, err = read_rest(proc, 120)
    assert proc.returncode == 0, err
    assert rtcf_shm_names() == []


@pytest.mark.parametrize(
    ("sig", "group"),
    [(signal.SIGINT, False), (signal.SIGTERM, False), (signal.SIGINT, True)],
    ids=["SIGINT", "SIGTERM", "Ctrl-C to the process group"],
)
def test_a_signal_stops_the_loop_runs_the_hooks_and_cleans_up(tmp_path, sig, group):
    path = write_launch(tmp_path, bomb(-1))
    proc = start("launch", path, start_new_session=group)
    m = wait_for_match(proc, r"loop in worker process (\d+)")
    worker = int(m.group(1))
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.3)
    # the run's memory is anonymous: there is no name that could leak
    assert rtcf_shm_names() == []
    if group:  # what a terminal does: the signal reaches supervisor and worker
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    out, err = read_rest(proc, 60)
    assert proc.returncode == 0, err
    assert f"{signal.Signals(sig).name}: stopping after this iteration" in err
    assert "Explodes stop hook ran" in err and "Explodes cleanup hook ran" in err
    assert " iterations at 200 Hz" in out
    assert wait_gone(worker)
    assert rtcf_shm_names() == []


def test_a_worker_killed_with_sigkill_is_reported_and_cleaned_up(tmp_path):
    proc = start("launch", write_launch(tmp_path, FACTS))
    m = wait_for_match(proc, r"loop in worker process (\d+)")
    worker = int(m.group(1))
    wait_for(proc, "running until Ctrl-C")
    time.sleep(0.3)
    os.kill(worker, signal.SIGKILL)
    _out, err = read_rest(proc, 60)
    assert proc.returncode == 1, err
    lines = [ln for ln in err.splitlines() if ln.startswith("rtcf: error:")]
    assert len(lines) == 1, err
    assert f"worker process (pid {worker}) was killed by SIGKILL" in lines[0]
    assert "stop() and cleanup() did not run" in lines[0]
    assert rtcf_shm_names() == []


def test_a_supervisor_killed_with_sigkill_takes_its_worker_along(tmp_path):
    path = write_launch(tmp_path, bomb(-1))
    proc = start("launch", path)
    m = wait_for_match(proc, r"loop in worker process (\d+)")
    worker = int(m.group(1))
    wait_for(proc, "real-time:")  # the loop has started: every segment is mapped
    proc.kill()
    read_rest(proc, 30)
    # the worker gets SIGTERM from the kernel (PR_SET_PDEATHSIG), stops and leaves
    assert wait_gone(worker), "the worker outlived its supervisor"
    assert rtcf_shm_names() == []


@pytest.mark.parametrize("sim", [True, False], ids=["sim", "real-time"])
def test_a_deadline_on_a_value_written_in_the_loop_applies_exactly(tmp_path, sim):
    # /src writes /x in the loop but in iterations 20-39; /reader's deadline of 50 ms
    # (5 iterations at 100 Hz) applies at 25 and the value is back at 40, in the worker,
    # under --sim and in real time alike (the loop's own clock decides, never the wall)
    path = write_launch(tmp_path, """
      <node name="src" pkg="rtcf" type="rt_launcher" args="rtcf_test_components PausingSource">
        <remap from="out" to="/x"/>
      </node>
      <node name="reader" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
        <remap from="in_port" to="/x"/>
        <param name="deadline/in_port" value="0.05"/>
      </node>""", runner_xml(100.0))
    report = tmp_path / "report"
    args = ["--duration", "0.5", "--report", str(report)] + (["--sim"] if sim else [])
    result = run_rtcf("launch", path, *args)
    assert result.returncode == 0, result.stderr
    timing = json.loads((report / "timing.json").read_text())
    (event,) = timing["deadline_events"]
    assert (event["iteration"], event["back_iteration"]) == (25, 40), event
    assert (event["last_arrival"], event["time"], event["back_time"]) == (0.19, 0.25, 0.4)
    assert "input '/reader.in_port' (/x) past its deadline of 0.05 s at iteration 25" in (
        result.stderr
    )


def test_a_raising_component_ends_the_run_with_its_name_and_cleans_up(tmp_path):
    path = write_launch(tmp_path, bomb(5))
    proc = start("launch", path, "--duration", "10")
    _out, err = read_rest(proc, 60)
    assert proc.returncode == 1, err
    lines = [ln for ln in err.splitlines() if ln.startswith("rtcf: error:")]
    assert len(lines) == 1 and "'/bomb'" in lines[0] and "iteration 5" in lines[0], err
    assert "Explodes cleanup hook ran" in err
    assert rtcf_shm_names() == []


def test_non_realtime_logging_in_update_is_an_error(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="slow" pkg="rtcf" type="rt_launcher"
            args="rtcf_test_components NonRtInUpdate"/>""",
    )
    result = run_rtcf("launch", path, "--duration", "1")
    assert result.returncode == 1
    lines = [ln for ln in result.stderr.splitlines() if ln.startswith("rtcf: error:")]
    assert len(lines) == 1, result.stderr
    assert "/slow" in lines[0] and "self.log.nonrt.info()" in lines[0]
    assert "while the loop runs" in lines[0] and "iteration 0" in lines[0]


def test_a_full_log_ring_drops_counts_and_reports(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="chatty" pkg="rtcf" type="rt_launcher" args="rtcf_test_components Chatty">
        <param name="n" value="6000"/>
      </node>""",
        runner=runner_xml(frequency=2.0),
    )
    result = run_rtcf("launch", path, "--duration", "1", "--report", tmp_path / "r")
    assert result.returncode == 0, result.stderr
    shown = len(re.findall(r"record \d+ of iteration", result.stderr))
    doc = json.loads((tmp_path / "r" / "timing.json").read_text())
    dropped = doc["log_records_dropped"]
    assert dropped > 0
    # every record was either shown or counted as dropped
    assert shown + dropped == 2 * 6000
    assert f"warning: {dropped} log records were dropped" in result.stderr


def test_live_status_line_on_a_terminal(tmp_path):
    path = write_launch(tmp_path, FACTS)
    controller, terminal = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "rtcf", "launch", str(path), "--duration", "1.5"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=terminal,
        env=env(),
    )
    os.close(terminal)
    data = b""
    while True:
        try:
            chunk = os.read(controller, 4096)
        except OSError:  # the terminal closed
            break
        if not chunk:
            break
        data += chunk
    proc.wait(timeout=60)
    os.close(controller)
    text = data.decode(errors="replace")
    assert proc.returncode == 0, text
    status = re.findall(r"\r\s*[\d.]+ s\s+(\d+) iterations\s+(\d+) overruns\s+jitter p99.9", text)
    assert status, text
    counts = [int(n) for n, _ in status]
    assert counts == sorted(counts) and counts[-1] > 0


def test_debug_shows_the_traceback_from_the_worker(tmp_path):
    path = write_launch(tmp_path, bomb(2))
    result = run_rtcf("launch", path, "--sim", "--duration", "1", "--debug")
    assert result.returncode == 1
    assert "Traceback" in result.stderr
    assert 'rtcf_test_components.py", line' in result.stderr  # the component's own frame
    assert "ZeroDivisionError: boom" in result.stderr
