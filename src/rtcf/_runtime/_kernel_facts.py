"""What the kernel and this process say about themselves, read without changing anything.

The real-time settings (:mod:`._realtime`, :mod:`._memory_lock`) check what they
asked for against these readings, and explain a refusal with them: the process's
capabilities and rlimits, the CPUs that exist and are online, the kernel's
preemption model and real-time throttling. ``rtcf report`` prints some of them too.
"""

from __future__ import annotations

import ctypes
import errno
import os
import platform
import resource
from pathlib import Path

PR_GET_TIMERSLACK = 30
SCHED_RESET_ON_FORK = 0x40000000

_POLICIES = {
    os.SCHED_OTHER: "SCHED_OTHER",
    os.SCHED_FIFO: "SCHED_FIFO",
    os.SCHED_RR: "SCHED_RR",
    os.SCHED_BATCH: "SCHED_BATCH",
    os.SCHED_IDLE: "SCHED_IDLE",
    6: "SCHED_DEADLINE",
}


# ----------------------------------------------------------------- pure helpers


def parse_cpu_list(text: str) -> set[int]:
    """CPUs from the kernel's list format, as in /sys/devices/system/cpu/online ("0-3,6")."""
    cpus: set[int] = set()
    for part in text.strip().split(","):
        if not part:
            continue
        lo, _, hi = part.partition("-")
        cpus.update(range(int(lo), int(hi or lo) + 1))
    return cpus


def rt_throttling_text(runtime_us: int | None, period_us: int | None) -> str:
    """Real-time throttling in words, from sched_rt_runtime_us and sched_rt_period_us."""
    if runtime_us is None:
        return "unknown (/proc/sys/kernel/sched_rt_runtime_us is not readable)"
    if runtime_us < 0:
        return f"off ({runtime_us})"
    period = "?" if period_us is None else str(period_us)
    return f"RT tasks may use {runtime_us} of every {period} µs"


def scheduler_name(policy: int) -> str:
    policy &= ~SCHED_RESET_ON_FORK
    return _POLICIES.get(policy, f"policy {policy}")


def errno_name(code: int) -> str:
    return errno.errorcode.get(code, f"errno {code}")


def limit_text(value: int, unit: int = 1, suffix: str = "") -> str:
    """An rlimit for a message: ``unlimited`` or the number (divided by ``unit``)."""
    if value == resource.RLIM_INFINITY:
        return "unlimited"
    return f"{value // unit}{suffix}"


# -------------------------------------------------------------- process readings


_libc_cache: list[ctypes.CDLL | None] = []


def c_library() -> ctypes.CDLL | None:
    if not _libc_cache:
        lib: ctypes.CDLL | None
        try:
            lib = ctypes.CDLL("libc.so.6", use_errno=True)
        except OSError:
            try:
                lib = ctypes.CDLL(None, use_errno=True)
            except OSError:
                lib = None
        _libc_cache.append(lib)
    return _libc_cache[0]


def proc_status() -> dict[str, str]:
    try:
        text = Path("/proc/self/status").read_text()
    except OSError:
        return {}
    out = {}
    for line in text.splitlines():
        key, _, value = line.partition(":")
        out[key] = value.strip()
    return out


def status_kB(key: str) -> int | None:
    value = proc_status().get(key, "")
    try:
        return int(value.split()[0])
    except (IndexError, ValueError):
        return None


def has_capability(bit: int) -> bool:
    try:
        return bool(int(proc_status().get("CapEff", "0"), 16) >> bit & 1)
    except ValueError:
        return False


def _read_int(path: str) -> int | None:
    try:
        return int(Path(path).read_text().strip())
    except (OSError, ValueError):
        return None


def kernel_preemption() -> str:
    """The kernel's preemption model, read from /sys/kernel/realtime and uname -v."""
    try:
        if Path("/sys/kernel/realtime").read_text().strip() == "1":
            return "PREEMPT_RT"
    except OSError:
        pass
    version = platform.version()
    for model in ("PREEMPT_RT", "PREEMPT_DYNAMIC", "PREEMPT"):
        if model in version:
            return model
    return "unknown"


def rt_throttling() -> str:
    return rt_throttling_text(
        _read_int("/proc/sys/kernel/sched_rt_runtime_us"),
        _read_int("/proc/sys/kernel/sched_rt_period_us"),
    )


def cpus_from_sysfs(name: str) -> set[int] | None:
    try:
        return parse_cpu_list(Path(f"/sys/devices/system/cpu/{name}").read_text())
    except (OSError, ValueError):
        return None


def timer_slack() -> int | None:
    libc = c_library()
    if libc is None:
        return None
    try:
        value = int(libc.prctl(PR_GET_TIMERSLACK, ctypes.c_ulong(0), 0, 0, 0))
    except AttributeError:
        return None
    return value if value >= 0 else None
