"""apply_realtime in child processes, checked against the child's own readings.

SCHED_FIFO and mlockall must never be applied to the pytest process, so every
test here starts a fresh interpreter that applies the settings and prints the
report next to what the kernel says about it (scheduler, affinity, VmLck, VmStk,
the size of the [stack] mapping).
"""

from __future__ import annotations

import json
import os
import pwd
import resource
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import pytest

from .conftest import SRC

pytestmark = pytest.mark.integration

CHILD = r"""
import json, os, pwd, sys

import rtcf._cli._report  # everything is imported before privileges are dropped
from rtcf._runtime._realtime import apply_realtime
from rtcf._runtime._realtime_report import describe_failures
from rtcf._core._settings import RunnerSettings


def stack_kB():
    with open("/proc/self/maps") as maps:
        for line in maps:
            if line.rstrip().endswith("[stack]"):
                lo, hi = (int(x, 16) for x in line.split()[0].split("-"))
                return (hi - lo) // 1024
    return None


def status_kB(key):
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return None


args = json.loads(sys.argv[1])
if args["user"]:
    # here, not in preexec_fn: the user may not be able to reach the interpreter's files
    pw = pwd.getpwnam(args["user"])
    os.setgroups([])
    os.setgid(pw.pw_gid)
    os.setuid(pw.pw_uid)
stack_before = stack_kB()
report = apply_realtime(RunnerSettings(**args["settings"]), simulated=args["simulated"])
policy = os.sched_getscheduler(0)
print(json.dumps({
    "report": report.to_dict(),
    "lines": report.lines(),
    "failures": describe_failures(report),
    "readback": {
        "uid": os.getuid(),
        "scheduler": policy,
        "priority": os.sched_getparam(0).sched_priority,
        "affinity": sorted(os.sched_getaffinity(0)),
        "VmLck": status_kB("VmLck"),
        "VmStk": status_kB("VmStk"),
        "stack_before_kB": stack_before,
        "stack_after_kB": stack_kB(),
    },
}))
"""

ALLOWED = sorted(os.sched_getaffinity(0))


def run_child(
    settings: dict[str, Any],
    *,
    simulated: bool = False,
    user: str | None = None,
    preexec_fn: Callable[[], None] | None = None,
) -> dict[str, Any]:
    """Apply ``settings`` in a fresh interpreter; its report and readings, as JSON."""
    env = {
        "PYTHONPATH": str(SRC),
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "PYTHONDONTWRITEBYTECODE": "1",
        "OPENBLAS_NUM_THREADS": "1",  # numpy's thread pool would only add locked memory
    }
    args = {"settings": settings, "simulated": simulated, "user": user}
    result = subprocess.run(
        [sys.executable, "-c", CHILD, json.dumps(args)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        cwd="/",
        preexec_fn=preexec_fn,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    out: dict[str, Any] = json.loads(result.stdout.splitlines()[-1])
    return out


def items(out: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {item["name"]: item for item in out["report"]["applied"]}


@pytest.mark.skipif(os.geteuid() != 0, reason="SCHED_FIFO and mlockall need root here")
def test_as_root_everything_requested_takes_effect() -> None:
    pin = 1 in ALLOWED and len(ALLOWED) >= 2
    settings = {
        "lock_memory": True,
        "safe_heap_size_kB": 512,
        "safe_stack_size_kB": 1024,
        "cpu_affinity_mask": 0b10 if pin else 0,
        "priority": 80,
    }
    out = run_child(settings)
    report, back = out["report"], out["readback"]
    applied = items(out)

    assert [i for i in applied.values() if not i["ok"]] == []
    assert out["failures"] is None
    expected = [
        "timer_slack", "heap_prefault", "stack_prefault", "mlockall", "scheduler", "cpu_dma_latency"
    ]
    if pin:
        expected.insert(1, "cpu_affinity")
    assert list(applied) == expected
    assert out["lines"][-2] == "scheduler: SCHED_FIFO priority 80: applied"
    assert out["lines"][-1] == "cpu_dma_latency: 0 µs: applied"

    assert back["scheduler"] == os.SCHED_FIFO and back["priority"] == 80
    assert (report["scheduler"], report["priority"]) == ("SCHED_FIFO", 80)
    if pin:
        assert back["affinity"] == [1]
        assert applied["cpu_affinity"]["requested"] == "CPUs [1]"
    assert report["cpu_affinity"] == back["affinity"]
    assert back["VmLck"] > 0
    assert report["mlockall"] is True
    assert "kB locked (VmLck)" in applied["mlockall"]["detail"]
    grown = back["stack_after_kB"] - back["stack_before_kB"]
    assert grown >= 1024
    assert back["VmStk"] >= back["stack_before_kB"] + 1024
    assert f"by {grown} kB" in applied["stack_prefault"]["detail"]
    assert "arenas" in applied["heap_prefault"]["detail"]
    assert report["kernel_preemption"] != ""
    assert report["rt_throttling"]


def _unprivileged_limits() -> None:
    """In the child, before exec: no real-time priority, 64 kB of lockable memory."""
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (64 * 1024, 64 * 1024))


@pytest.mark.skipif(os.geteuid() != 0, reason="dropping privileges to nobody needs root")
def test_refusals_are_reported_not_raised() -> None:
    nobody = pwd.getpwnam("nobody")
    settings = {"lock_memory": True, "safe_stack_size_kB": 256, "priority": 80}
    out = run_child(settings, user="nobody", preexec_fn=_unprivileged_limits)
    report, back = out["report"], out["readback"]
    applied = items(out)

    assert back["uid"] == nobody.pw_uid
    assert back["scheduler"] == os.SCHED_OTHER
    assert report["scheduler"] == "SCHED_OTHER" and report["priority"] is None
    sched = applied["scheduler"]
    assert not sched["ok"]
    assert sched["detail"].startswith("EPERM")
    assert "RLIMIT_RTPRIO" in sched["detail"] and "ulimit -r" in sched["detail"]
    assert sched["detail"].endswith("running with SCHED_OTHER")
    lock = applied["mlockall"]
    assert not lock["ok"]
    assert "ulimit -l" in lock["detail"] and "64 kB" in lock["detail"]
    assert report["mlockall"] is False
    assert back["VmLck"] == 0
    # what an unprivileged process may do still happens
    assert applied["timer_slack"]["ok"]
    assert applied["stack_prefault"]["ok"]
    assert back["stack_after_kB"] - back["stack_before_kB"] >= 256
    assert out["failures"].startswith("real-time settings not in effect: ")
    assert "mlockall (ENOMEM" in out["failures"] and "scheduler (EPERM" in out["failures"]


@pytest.mark.skipif(63 in ALLOWED, reason="this machine may use CPU 63")
def test_a_mask_naming_only_a_missing_cpu_is_not_applied() -> None:
    out = run_child({"cpu_affinity_mask": 1 << 63, "priority": 1})
    item = items(out)["cpu_affinity"]
    assert item["requested"] == "CPUs [63]"
    assert not item["ok"]
    assert "CPU 63" in item["detail"]
    assert f"allowed are CPUs {ALLOWED}" in item["detail"]
    assert out["readback"]["affinity"] == ALLOWED
    assert out["report"]["cpu_affinity"] == ALLOWED


@pytest.mark.skipif(63 in ALLOWED, reason="this machine may use CPU 63")
def test_a_mask_partly_outside_the_machine_applies_the_rest() -> None:
    first = ALLOWED[0]
    out = run_child({"cpu_affinity_mask": (1 << 63) | (1 << first), "priority": 1})
    item = items(out)["cpu_affinity"]
    assert not item["ok"]  # not what was asked for; the report says what was done instead
    assert "CPU 63" in item["detail"]
    assert f"pinned to CPUs [{first}] only" in item["detail"]
    assert out["readback"]["affinity"] == [first]


def test_simulated_applies_nothing() -> None:
    settings = {
        "lock_memory": True,
        "safe_heap_size_kB": 512,
        "safe_stack_size_kB": 1024,
        "cpu_affinity_mask": 0b1,
        "priority": 80,
    }
    out = run_child(settings, simulated=True)
    report, back = out["report"], out["readback"]
    applied = items(out)
    assert set(applied) == {
        "timer_slack",
        "cpu_affinity",
        "heap_prefault",
        "stack_prefault",
        "mlockall",
        "scheduler",
        "cpu_dma_latency",
    }
    for item in applied.values():
        assert (item["ok"], item["detail"]) == (False, "simulated clock (--sim)")
    assert all(line.endswith(": not applied: simulated clock (--sim)") for line in out["lines"])
    assert out["failures"].startswith("simulated clock (--sim)")
    assert back["scheduler"] == os.sched_getscheduler(0)
    assert report["scheduler"] == "SCHED_OTHER" or os.sched_getscheduler(0) != os.SCHED_OTHER
    assert back["affinity"] == ALLOWED
    assert back["VmLck"] == 0 and report["mlockall"] is False
    assert back["stack_after_kB"] - back["stack_before_kB"] < 1024
    assert report["kernel_preemption"]
    assert report["rt_throttling"]
