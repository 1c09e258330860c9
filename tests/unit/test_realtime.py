"""The real-time report's pure parts, and FrozenGC on this process.

apply_realtime itself only ever runs in child processes (tests/integration):
SCHED_FIFO or mlockall on the pytest process would outlive the test.
"""

from __future__ import annotations

import errno
import gc
import os
import resource
from collections.abc import Iterator
from pathlib import Path

import pytest

from rtcf._runtime._kernel_facts import (
    parse_cpu_list,
    rt_throttling,
    rt_throttling_text,
    scheduler_name,
)
from rtcf._runtime._memory_lock import mlockall_refusal, stack_mapping
from rtcf._runtime._realtime import (
    FrozenGC,
    cpus_from_mask,
    format_cpus,
    scheduler_refusal,
)
from rtcf._runtime._realtime_report import (
    SIMULATED,
    Applied,
    RealtimeReport,
    describe_failures,
)


def _report(*items: Applied, simulated: bool = False) -> RealtimeReport:
    return RealtimeReport(
        items=list(items),
        scheduler="SCHED_FIFO",
        priority=80,
        cpu_affinity=[1],
        mlockall=True,
        kernel_preemption="PREEMPT_DYNAMIC",
        rt_throttling="RT tasks may use 950000 of every 1000000 µs",
        simulated=simulated,
    )


SCHED_OK = Applied("scheduler", "SCHED_FIFO priority 80", True, "SCHED_FIFO priority 80")
SCHED_EPERM = Applied(
    "scheduler",
    "SCHED_FIFO priority 80",
    False,
    "EPERM: needs root, CAP_SYS_NICE or an RLIMIT_RTPRIO of at least 80 "
    "(ulimit -r, now 0; rtprio in /etc/security/limits.conf); running with SCHED_OTHER",
)
MLOCK_ENOMEM = Applied(
    "mlockall",
    "MCL_CURRENT | MCL_FUTURE",
    False,
    "ENOMEM: RLIMIT_MEMLOCK is 64 kB (ulimit -l); raise it or run as root; "
    "pages may be swapped out",
)


@pytest.mark.parametrize(
    ("mask", "cpus"),
    [(0, []), (0b1, [0]), (0b10, [1]), (0b1011, [0, 1, 3]), (1 << 63, [63]), (0xF0, [4, 5, 6, 7])],
)
def test_cpus_from_mask(mask: int, cpus: list[int]) -> None:
    assert cpus_from_mask(mask) == cpus


def test_negative_mask_is_a_programming_error() -> None:
    with pytest.raises(ValueError, match="negative"):
        cpus_from_mask(-1)


@pytest.mark.parametrize(
    ("text", "cpus"),
    [("0-3,6\n", {0, 1, 2, 3, 6}), ("0", {0}), ("0-1", {0, 1}), ("", set()), ("2,4-5", {2, 4, 5})],
)
def test_parse_cpu_list(text: str, cpus: set[int]) -> None:
    assert parse_cpu_list(text) == cpus


def test_format_cpus_is_sorted() -> None:
    assert format_cpus({1, 0}) == "CPUs [0, 1]"
    assert format_cpus([1]) == "CPUs [1]"


def test_rt_throttling_text() -> None:
    assert rt_throttling_text(950000, 1000000) == "RT tasks may use 950000 of every 1000000 µs"
    assert rt_throttling_text(-1, 1000000) == "off (-1)"
    assert rt_throttling_text(None, None).startswith("unknown")
    assert rt_throttling_text(950000, None) == "RT tasks may use 950000 of every ? µs"


def test_rt_throttling_reads_proc() -> None:
    runtime = Path("/proc/sys/kernel/sched_rt_runtime_us")
    period = Path("/proc/sys/kernel/sched_rt_period_us")
    if not runtime.exists():
        pytest.skip("no /proc/sys/kernel/sched_rt_runtime_us")
    expected = rt_throttling_text(
        int(runtime.read_text()), int(period.read_text()) if period.exists() else None
    )
    assert rt_throttling() == expected


def test_scheduler_name_ignores_reset_on_fork() -> None:
    assert scheduler_name(os.SCHED_OTHER) == "SCHED_OTHER"
    assert scheduler_name(os.SCHED_FIFO | 0x40000000) == "SCHED_FIFO"
    assert scheduler_name(42) == "policy 42"


def test_scheduler_refusal_names_the_limit_and_the_fix() -> None:
    text = scheduler_refusal(80, 0, 1000, cap_sys_nice=False)
    assert text.startswith("EPERM: needs root, CAP_SYS_NICE or an RLIMIT_RTPRIO of at least 80")
    assert "ulimit -r, now 0" in text
    unlimited = scheduler_refusal(80, resource.RLIM_INFINITY, 1000, cap_sys_nice=False)
    assert "now unlimited" in unlimited
    assert "container" in scheduler_refusal(80, 0, 0, cap_sys_nice=False)
    assert "cpu.rt_runtime_us" in scheduler_refusal(80, 0, 0, cap_sys_nice=True)


def test_mlockall_refusal_names_the_limit_and_the_fix() -> None:
    text = mlockall_refusal(errno.ENOMEM, 64 * 1024, 150000, cap=False)
    assert text.startswith("ENOMEM: RLIMIT_MEMLOCK is 64 kB (ulimit -l)")
    assert "150000 kB" in text and "run as root" in text
    assert "not enough free memory" in mlockall_refusal(errno.ENOMEM, 64 * 1024, None, cap=True)
    assert "CAP_IPC_LOCK" in mlockall_refusal(errno.EPERM, 0, None, cap=False)
    assert mlockall_refusal(errno.EAGAIN, 0, None, cap=False).startswith("EAGAIN: ")


def test_stack_mapping_from_maps_text() -> None:
    maps = (
        "55d0c0000000-55d0c0021000 rw-p 00000000 00:00 0          [heap]\n"
        "7f0000000000-7f0000001000 r--p 00000000 fe:00 12   /usr/lib/libc.so.6\n"
        "7ffc9464f000-7ffc94670000 rw-p 00000000 00:00 0          [stack]\n"
        "7ffc946f0000-7ffc946f4000 r--p 00000000 00:00 0          [vvar]\n"
    )
    assert stack_mapping(maps) == (0x7FFC9464F000, 0x7FFC94670000, 0x7F0000001000)
    assert stack_mapping(maps.replace("[stack]", "")) is None


def test_stack_mapping_of_this_process() -> None:
    found = stack_mapping(Path("/proc/self/maps").read_text())
    assert found is not None
    lo, hi, below = found
    assert below < lo < hi


def test_lines_are_short_and_say_applied_or_why_not() -> None:
    report = _report(
        Applied("timer_slack", "1 ns", True, "1 ns (was 50000 ns)"), SCHED_OK, MLOCK_ENOMEM
    )
    assert report.lines() == [
        "timer_slack: 1 ns: applied",
        "scheduler: SCHED_FIFO priority 80: applied",
        "mlockall: not applied: " + MLOCK_ENOMEM.detail,
    ]
    assert report.not_applied == [MLOCK_ENOMEM]


def test_describe_failures_is_none_when_everything_took_effect() -> None:
    assert describe_failures(_report(SCHED_OK)) is None
    assert describe_failures(_report()) is None


def test_describe_failures_is_one_sentence_with_reasons() -> None:
    text = describe_failures(_report(SCHED_OK, SCHED_EPERM, MLOCK_ENOMEM))
    assert text is not None
    assert text.startswith("real-time settings not in effect: scheduler (EPERM: needs root")
    assert "(ulimit -r, now 0; rtprio in /etc/security/limits.conf)" in text
    assert "mlockall (ENOMEM: RLIMIT_MEMLOCK is 64 kB (ulimit -l))" in text
    assert "running with SCHED_OTHER" not in text  # the reason only, not the aftermath
    assert "pages may be swapped out" not in text
    assert "\n" not in text and ". " not in text


def test_describe_failures_when_simulated() -> None:
    items = [Applied(n, "x", False, SIMULATED) for n in ("timer_slack", "scheduler")]
    text = describe_failures(_report(*items, simulated=True))
    assert text is not None and text.startswith("simulated clock (--sim)")


def test_to_dict_has_the_timing_json_keys() -> None:
    report = _report(SCHED_OK, MLOCK_ENOMEM)
    doc = report.to_dict()
    assert list(doc) == [
        "scheduler",
        "priority",
        "mlockall",
        "cpu_affinity",
        "kernel_preemption",
        "rt_throttling",
        "gc",
        "applied",
        "hot_path",
    ]
    assert doc["hot_path"]["path"] in ("compiled", "Python")
    assert doc["gc"] == "left as is (FrozenGC not used)"
    assert doc["applied"][1] == {
        "name": "mlockall",
        "requested": "MCL_CURRENT | MCL_FUTURE",
        "ok": False,
        "detail": MLOCK_ENOMEM.detail,
    }


@pytest.fixture
def restore_gc() -> Iterator[None]:
    """FrozenGC changes process-wide state; put it back whatever a test did."""
    enabled = gc.isenabled()
    frozen = gc.get_freeze_count()
    yield
    if frozen == 0:
        gc.unfreeze()
    if enabled:
        gc.enable()
    else:
        gc.disable()


@pytest.mark.usefixtures("restore_gc")
def test_frozen_gc_freezes_disables_and_restores() -> None:
    gc.enable()
    gc.unfreeze()
    report = _report(SCHED_OK)
    with FrozenGC(report) as frozen:
        assert not gc.isenabled()
        assert gc.get_freeze_count() > 0
        assert frozen.frozen_objects > 0  # some may have died since, so not ==
        item = report.item("gc")
        assert item is not None and item.ok
        assert item.detail.startswith("frozen and disabled while running")
    assert gc.isenabled()
    assert gc.get_freeze_count() == 0
    assert frozen.collections_during_run == 0
    assert report.to_dict()["gc"].startswith("frozen and disabled while running (")
    assert "no collections during the run" in report.to_dict()["gc"]
    assert [i.name for i in report.items] == ["scheduler", "gc"]


@pytest.mark.usefixtures("restore_gc")
def test_frozen_gc_counts_collections_during_the_run() -> None:
    gc.enable()
    with FrozenGC() as frozen:
        gc.collect()
        gc.collect(0)
    assert frozen.collections_during_run == 2
    assert "2 collections ran anyway" in frozen.summary()


@pytest.mark.usefixtures("restore_gc")
def test_frozen_gc_leaves_a_disabled_collector_disabled_and_others_freeze_alone() -> None:
    gc.disable()
    gc.freeze()
    before = gc.get_freeze_count()
    with FrozenGC() as frozen:
        assert not gc.isenabled()
    assert not gc.isenabled()
    assert gc.get_freeze_count() >= before  # nothing unfrozen that someone else froze
    assert "left disabled" in frozen.summary()


@pytest.mark.usefixtures("restore_gc")
def test_frozen_gc_does_nothing_for_a_simulated_run() -> None:
    gc.enable()
    frozen_before = gc.get_freeze_count()
    report = _report(simulated=True)
    with FrozenGC(report):
        assert gc.isenabled()
        assert gc.get_freeze_count() == frozen_before
    assert report.to_dict()["gc"] == f"not applied: {SIMULATED}"
    assert report.lines() == [f"gc: not applied: {SIMULATED}"]
