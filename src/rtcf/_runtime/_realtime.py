"""Real-time settings for the worker process, applied before its loop starts.

Each setting is tried on its own and the result is reported in plain words: a
runner that silently runs with normal scheduling or unlocked memory produces
timing that looks like a bug in the components. Nothing here raises for a
refused setting; the report says what took effect, what did not, why, and the fix.

All settings except ``mlockall`` act on the calling thread (Linux schedules
threads): call :func:`apply_realtime` from the thread that runs the loop, before
starting threads that should inherit them.

This module holds the thread's settings (timer slack, CPU affinity, SCHED_FIFO,
cpu_dma_latency), the order they are applied in, and the collector kept out of
the run (:class:`FrozenGC`). The memory steps are in :mod:`._memory_lock`, the
readings of the kernel they are checked against in :mod:`._kernel_facts`, and
the report they fill in :mod:`._realtime_report`.
"""

from __future__ import annotations

import errno
import gc
import os
import resource
import sys
from types import TracebackType
from typing import Any

from .._core._clock import set_timer_slack
from .._core._settings import RunnerSettings
from ._kernel_facts import (
    SCHED_RESET_ON_FORK,
    cpus_from_sysfs,
    errno_name,
    has_capability,
    kernel_preemption,
    limit_text,
    rt_throttling,
    scheduler_name,
    timer_slack,
)
from ._memory_lock import step_heap, step_mlockall, step_stack
from ._realtime_report import SIMULATED, Applied, RealtimeReport

TIMER_SLACK_NS = 1
CAP_SYS_NICE = 23


# ----------------------------------------------------------------- pure helpers


def cpus_from_mask(mask: int) -> list[int]:
    """The CPUs named by an affinity bit mask (bit n = CPU n), ascending."""
    if mask < 0:
        raise ValueError(f"CPU mask {mask} is negative")
    return [n for n in range(mask.bit_length()) if mask >> n & 1]


def format_cpus(cpus: set[int] | list[int]) -> str:
    """``CPUs [0, 1]``: the form used in every message about affinity."""
    return f"CPUs {sorted(cpus)}"


def scheduler_refusal(priority: int, rtprio_limit: int, euid: int, cap_sys_nice: bool) -> str:
    """Why sched_setscheduler said EPERM, and what to change."""
    limit = limit_text(rtprio_limit)
    if cap_sys_nice:
        return (
            "EPERM although the process has CAP_SYS_NICE: its cgroup has no real-time budget "
            "(RT group scheduling: give it cpu.rt_runtime_us, or run outside it)"
        )
    if euid == 0:
        return (
            f"EPERM: root without CAP_SYS_NICE (a container? add the SYS_NICE capability) "
            f"and RLIMIT_RTPRIO is {limit} (ulimit -r), below {priority}"
        )
    return (
        f"EPERM: needs root, CAP_SYS_NICE or an RLIMIT_RTPRIO of at least {priority} "
        f"(ulimit -r, now {limit}; rtprio in /etc/security/limits.conf)"
    )


# ------------------------------------------------------------------------ steps

_DMA_LATENCY_FD: list[int] = []  # held open while the process lives: closing it ends the request


def _step_dma_latency() -> Applied:
    """Ask the kernel to keep CPUs out of deep idle states, as cyclictest does.

    Waking a CPU from a deep C-state adds tens of microseconds to a wake-up; the
    request holds while /dev/cpu_dma_latency stays open (for this worker's life).
    """
    if _DMA_LATENCY_FD:
        return Applied("cpu_dma_latency", "0 µs", True, "held at 0 µs (since an earlier run)")
    try:
        fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY | os.O_CLOEXEC)
    except OSError as exc:
        return Applied(
            "cpu_dma_latency",
            "0 µs",
            False,
            f"{errno.errorcode.get(exc.errno or 0, exc.errno)}: cannot open /dev/cpu_dma_latency "
            "(needs root); deep CPU idle states may add wake-up latency",
        )
    os.write(fd, (0).to_bytes(4, sys.byteorder))
    _DMA_LATENCY_FD.append(fd)
    return Applied(
        "cpu_dma_latency", "0 µs", True, "held at 0 µs while the worker runs (no deep C-states)"
    )


def _step_timer_slack() -> Applied:
    requested = f"{TIMER_SLACK_NS} ns"
    before = timer_slack()
    ok = set_timer_slack(TIMER_SLACK_NS)
    after = timer_slack()
    if ok and after in (None, TIMER_SLACK_NS):
        was = "" if before is None else f" (was {before} ns)"
        return Applied(
            "timer_slack",
            requested,
            True,
            f"{TIMER_SLACK_NS} ns{was}; matters only under SCHED_OTHER, "
            "real-time threads get no slack",
        )
    if after == 0 and os.sched_getscheduler(0) & ~SCHED_RESET_ON_FORK in (
        os.SCHED_FIFO,
        os.SCHED_RR,
    ):
        return Applied(
            "timer_slack",
            requested,
            True,
            "the thread is already real-time: the kernel gives it no slack at all",
        )
    now = "unknown" if after is None else f"{after} ns"
    return Applied(
        "timer_slack",
        requested,
        False,
        f"prctl(PR_SET_TIMERSLACK) did not take effect (slack is {now}); under SCHED_OTHER "
        "wake-ups may come up to 50 µs late",
    )


def _step_affinity(mask: int, allowed: set[int]) -> Applied:
    wanted = set(cpus_from_mask(mask))
    requested = format_cpus(wanted)
    problems = []
    missing = sorted(wanted - allowed)
    if missing:
        possible = cpus_from_sysfs("possible")
        online = cpus_from_sysfs("online") or possible or set(range(os.cpu_count() or 1))
        groups: dict[str, list[int]] = {}
        for cpu in missing:
            if cpu in online:
                why = "not allowed for this process (cpuset or taskset)"
            elif possible is not None and cpu in possible:
                why = "offline"
            else:
                why = "nonexistent"
            groups.setdefault(why, []).append(cpu)
        for why, cpus in groups.items():
            who = f"CPU {cpus[0]}" if len(cpus) == 1 else f"CPUs {cpus}"
            verb = "is" if len(cpus) == 1 else "are"
            if why == "nonexistent":
                problems.append(
                    f"{who} {'does' if len(cpus) == 1 else 'do'} not exist "
                    f"(this machine has {format_cpus(online)})"
                )
            else:
                problems.append(f"{who} {verb} {why}")
        problems.append(f"allowed are {format_cpus(allowed)}")
    target = wanted & allowed
    if not target:
        return Applied(
            "cpu_affinity",
            requested,
            False,
            "; ".join(
                [*problems, f"affinity left at {format_cpus(allowed)}; fix cpu_affinity_mask"]
            ),
        )
    try:
        os.sched_setaffinity(0, target)
    except OSError as exc:
        code = exc.errno or 0
        return Applied(
            "cpu_affinity",
            requested,
            False,
            "; ".join(
                [
                    f"{errno_name(code)}: {os.strerror(code)}",
                    *problems,
                    f"affinity left at {format_cpus(os.sched_getaffinity(0))}",
                ]
            ),
        )
    now = os.sched_getaffinity(0)
    if now != target:
        return Applied(
            "cpu_affinity",
            requested,
            False,
            "; ".join(
                [
                    *problems,
                    f"asked for {format_cpus(target)} but the kernel "
                    f"runs the thread on {format_cpus(now)}",
                ]
            ),
        )
    if problems:
        return Applied(
            "cpu_affinity",
            requested,
            False,
            "; ".join([*problems, f"pinned to {format_cpus(now)} only"]),
        )
    return Applied("cpu_affinity", requested, True, f"pinned to {format_cpus(now)}")


def _step_scheduler(priority: int) -> Applied:
    requested = f"SCHED_FIFO priority {priority}"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        code = exc.errno or 0
        policy = scheduler_name(os.sched_getscheduler(0))
        if code == errno.EPERM:
            rtprio, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
            why = scheduler_refusal(priority, rtprio, os.geteuid(), has_capability(CAP_SYS_NICE))
        else:
            why = f"{errno_name(code)}: {os.strerror(code)}"
        return Applied("scheduler", requested, False, f"{why}; running with {policy}")
    policy_id = os.sched_getscheduler(0) & ~SCHED_RESET_ON_FORK
    got = os.sched_getparam(0).sched_priority
    if policy_id != os.SCHED_FIFO or got != priority:
        return Applied(
            "scheduler",
            requested,
            False,
            f"the kernel reports {scheduler_name(policy_id)} priority {got}",
        )
    return Applied("scheduler", requested, True, f"SCHED_FIFO priority {got} (read back)")


def _guarded(name: str, requested: str, step: Any, *args: Any) -> Any:
    """Run one step; an OSError becomes a report item so the next steps still run."""
    try:
        return step(*args)
    except OSError as exc:
        code = exc.errno or 0
        return Applied(name, requested, False, f"{errno_name(code)}: {exc.strerror or exc}")


def apply_realtime(settings: RunnerSettings, *, simulated: bool = False) -> RealtimeReport:
    """Apply the runner's real-time settings to this process and thread; report each.

    Order: timer slack, CPU affinity, heap and stack pre-faulting (before mlockall,
    which then locks what they faulted in), mlockall, SCHED_FIFO last (so the
    slow steps above do not run at real-time priority). With ``simulated`` nothing
    is applied; every requested item says so.
    """

    allowed = os.sched_getaffinity(0)
    wanted: list[tuple[str, str]] = [("timer_slack", f"{TIMER_SLACK_NS} ns")]
    if settings.cpu_affinity_mask:
        wanted.append(("cpu_affinity", format_cpus(cpus_from_mask(settings.cpu_affinity_mask))))
    if settings.safe_heap_size_kB > 0:
        wanted.append(("heap_prefault", f"{settings.safe_heap_size_kB} kB"))
    if settings.safe_stack_size_kB > 0:
        wanted.append(("stack_prefault", f"{settings.safe_stack_size_kB} kB"))
    if settings.lock_memory:
        wanted.append(("mlockall", "MCL_CURRENT | MCL_FUTURE"))
    wanted.append(("scheduler", f"SCHED_FIFO priority {settings.priority}"))
    wanted.append(("cpu_dma_latency", "0 µs"))

    items: list[Applied] = []
    locked = False
    if simulated:
        items = [Applied(name, req, False, SIMULATED) for name, req in wanted]
    else:
        for name, req in wanted:
            if name == "timer_slack":
                items.append(_guarded(name, req, _step_timer_slack))
            elif name == "cpu_affinity":
                items.append(
                    _guarded(name, req, _step_affinity, settings.cpu_affinity_mask, allowed)
                )
            elif name == "heap_prefault":
                items.append(_guarded(name, req, step_heap, settings.safe_heap_size_kB))
            elif name == "stack_prefault":
                items.append(_guarded(name, req, step_stack, settings.safe_stack_size_kB))
            elif name == "mlockall":
                result = _guarded(name, req, step_mlockall)
                item, locked = result if isinstance(result, tuple) else (result, False)
                items.append(item)
            elif name == "cpu_dma_latency":
                items.append(_guarded(name, req, _step_dma_latency))
            else:
                items.append(_guarded(name, req, _step_scheduler, settings.priority))

    policy = os.sched_getscheduler(0) & ~SCHED_RESET_ON_FORK
    priority = (
        os.sched_getparam(0).sched_priority if policy in (os.SCHED_FIFO, os.SCHED_RR) else None
    )
    return RealtimeReport(
        items=items,
        scheduler=scheduler_name(policy),
        priority=priority,
        cpu_affinity=sorted(os.sched_getaffinity(0)),
        mlockall=locked,
        kernel_preemption=kernel_preemption(),
        rt_throttling=rt_throttling(),
        simulated=simulated,
    )


class FrozenGC:
    """Keeps the cyclic garbage collector out of the loop while it runs.

    On enter: ``gc.collect(); gc.freeze(); gc.disable()`` so no collection pauses
    an iteration and the objects alive at start are never scanned again. On exit,
    if the collector was enabled before: ``gc.enable()`` and ``gc.unfreeze()`` (the
    latter only if nothing was frozen before, so someone else's freeze is kept).
    ``collections_during_run`` counts collections that ran anyway (an explicit
    ``gc.collect()``). Given a report, records a ``gc`` item in it; given a report
    of a simulated run, does nothing but record that.
    """

    def __init__(self, report: RealtimeReport | None = None) -> None:
        self.report = report
        self.active = not (report is not None and report.simulated)
        self.collections_during_run = 0
        self.frozen_objects = 0
        self._was_enabled = False
        self._freeze_before = 0
        self._start = 0
        self._inside = False

    def __enter__(self) -> FrozenGC:
        self._inside = True
        if not self.active:
            self._record(False, SIMULATED)
            return self
        self._was_enabled = gc.isenabled()
        self._freeze_before = gc.get_freeze_count()
        gc.collect()
        gc.freeze()
        gc.disable()
        self.frozen_objects = gc.get_freeze_count()
        self._start = _collections()
        self._record(True, self.summary())
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._inside = False
        if not self.active:
            return
        self.collections_during_run = _collections() - self._start
        if self._was_enabled:
            gc.enable()
            if self._freeze_before == 0:
                gc.unfreeze()
        self._record(True, self.summary())

    def summary(self) -> str:
        """What happened, as it goes into timing.json's ``realtime.gc``."""
        if not self.active:
            return f"not applied: {SIMULATED}"
        text = f"frozen and disabled while running ({self.frozen_objects} objects frozen"
        if not self._inside:
            n = self.collections_during_run
            text += (
                "; no collections during the run"
                if n == 0
                else f"; {n} collection{'s' if n != 1 else ''} ran anyway (gc.collect() called)"
            )
        if not self._was_enabled:
            text += "; it was disabled before and is left disabled"
        return text + ")"

    def _record(self, ok: bool, detail: str) -> None:
        if self.report is None:
            return
        item = Applied("gc", "collect, freeze and disable the collector while running", ok, detail)
        items = self.report.items
        for n, old in enumerate(items):
            if old.name == "gc":
                items[n] = item
                return
        items.append(item)


def _collections() -> int:
    return sum(int(stats["collections"]) for stats in gc.get_stats())
