"""Real-time settings for the worker process, applied before its loop starts.

Each setting is tried on its own and the result is reported in plain words: a
runner that silently runs with normal scheduling or unlocked memory produces
timing that looks like a bug in the components. Nothing here raises for a
refused setting; the report says what took effect, what did not, why, and the fix.

All settings except ``mlockall`` act on the calling thread (Linux schedules
threads): call :func:`apply_realtime` from the thread that runs the loop, before
starting threads that should inherit them.
"""

from __future__ import annotations

import ctypes
import errno
import gc
import mmap
import os
import platform
import resource
import sys
import threading
from dataclasses import asdict, dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

from .._core import _hotpath
from .._core._clock import set_timer_slack
from .._core._settings import RunnerSettings

SIMULATED = "simulated clock (--sim)"
PAGE = mmap.PAGESIZE
STACK_MARGIN = 256 * 1024  # kept free below RLIMIT_STACK
STACK_GUARD_GAP = 1024 * 1024  # the kernel's default stack_guard_gap (256 pages)
STACK_SP_CLEARANCE = 64 * 1024  # never touch closer than this below the stack pointer
TIMER_SLACK_NS = 1

PR_GET_TIMERSLACK = 30
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
MCL_CURRENT = 1
MCL_FUTURE = 2
CAP_IPC_LOCK = 14
CAP_SYS_NICE = 23
SCHED_RESET_ON_FORK = 0x40000000

_POLICIES = {
    os.SCHED_OTHER: "SCHED_OTHER",
    os.SCHED_FIFO: "SCHED_FIFO",
    os.SCHED_RR: "SCHED_RR",
    os.SCHED_BATCH: "SCHED_BATCH",
    os.SCHED_IDLE: "SCHED_IDLE",
    6: "SCHED_DEADLINE",
}


@dataclass
class Applied:
    """One setting: what was asked for, whether it took effect, and what happened."""

    name: str
    requested: str
    ok: bool
    detail: str


@dataclass
class RealtimeReport:
    """What :func:`apply_realtime` did, with the state read back from the kernel."""

    items: list[Applied]
    scheduler: str
    priority: int | None
    cpu_affinity: list[int]
    mlockall: bool
    kernel_preemption: str
    rt_throttling: str
    simulated: bool = False

    @property
    def not_applied(self) -> list[Applied]:
        return [item for item in self.items if not item.ok]

    def item(self, name: str) -> Applied | None:
        return next((i for i in self.items if i.name == name), None)

    def to_dict(self) -> dict[str, Any]:
        """The ``realtime`` section of timing.json."""
        gc_item = self.item("gc")
        if gc_item is None:
            gc_text = "left as is (FrozenGC not used)"
        else:
            gc_text = gc_item.detail if gc_item.ok else f"not applied: {gc_item.detail}"
        return {
            "scheduler": self.scheduler,
            "priority": self.priority,
            "mlockall": self.mlockall,
            "cpu_affinity": list(self.cpu_affinity),
            "kernel_preemption": self.kernel_preemption,
            "rt_throttling": self.rt_throttling,
            "gc": gc_text,
            "applied": [asdict(i) for i in self.items],
            # which hot path this process's loop runs: compiled, or Python and why
            "hot_path": {"path": _hotpath.HOT_PATH, "why": _hotpath.WHY,
                         # what times each component: the TSC, or clock_gettime
                         "component_clock": _hotpath.component_clock()[0]},
        }

    def lines(self) -> list[str]:
        """One short line per setting, for the start-up log."""
        return [
            f"{i.name}: {i.requested}: applied" if i.ok else f"{i.name}: not applied: {i.detail}"
            for i in self.items
        ]


# ----------------------------------------------------------------- pure helpers


def cpus_from_mask(mask: int) -> list[int]:
    """The CPUs named by an affinity bit mask (bit n = CPU n), ascending."""
    if mask < 0:
        raise ValueError(f"CPU mask {mask} is negative")
    return [n for n in range(mask.bit_length()) if mask >> n & 1]


def parse_cpu_list(text: str) -> set[int]:
    """CPUs from the kernel's list format, as in /sys/devices/system/cpu/online ("0-3,6")."""
    cpus: set[int] = set()
    for part in text.strip().split(","):
        if not part:
            continue
        lo, _, hi = part.partition("-")
        cpus.update(range(int(lo), int(hi or lo) + 1))
    return cpus


def format_cpus(cpus: set[int] | list[int]) -> str:
    """``CPUs [0, 1]``: the form used in every message about affinity."""
    return f"CPUs {sorted(cpus)}"


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


def mlockall_refusal(code: int, memlock_limit: int, vm_size_kB: int | None, cap: bool) -> str:
    """Why mlockall failed, and what to change."""
    size = "" if vm_size_kB is None else f", the process maps {vm_size_kB} kB"
    if code == errno.ENOMEM:
        if cap:
            return f"ENOMEM: not enough free memory to lock the process{size}"
        return (
            f"ENOMEM: RLIMIT_MEMLOCK is {limit_text(memlock_limit, 1024, ' kB')} "
            f"(ulimit -l){size}; raise it (ulimit -l unlimited, memlock in "
            "/etc/security/limits.conf) or run as root"
        )
    if code == errno.EPERM:
        return (
            f"EPERM: needs CAP_IPC_LOCK (run as root) or a larger RLIMIT_MEMLOCK "
            f"(ulimit -l, now {limit_text(memlock_limit, 1024, ' kB')})"
        )
    return f"{errno_name(code)}: {os.strerror(code)}"


def describe_failures(report: RealtimeReport) -> str | None:
    """One sentence for the start-up banner on what did not take effect (None: all did)."""
    failed = report.not_applied
    if not failed:
        return None
    if all(i.detail == SIMULATED for i in failed):
        return "simulated clock (--sim): no real-time settings applied; timing is not measured"
    parts = [f"{i.name} ({_first_clause(i.detail)})" for i in failed]
    return (
        "real-time settings not in effect: "
        + ", ".join(parts)
        + "; expect more jitter than the machine can deliver"
    )


def _first_clause(text: str) -> str:
    """Text up to the first ``; `` outside parentheses: the reason without the aftermath."""
    depth = 0
    for n, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(0, depth - 1)
        elif ch == ";" and depth == 0:
            return text[:n]
    return text


def stack_mapping(maps: str) -> tuple[int, int, int] | None:
    """(start, end, end of the mapping below) of ``[stack]`` in /proc/<pid>/maps text."""
    below = 0
    for line in maps.splitlines():
        fields = line.split()
        if not fields:
            continue
        lo_text, _, hi_text = fields[0].partition("-")
        lo, hi = int(lo_text, 16), int(hi_text, 16)
        if len(fields) >= 6 and fields[5] == "[stack]":
            return lo, hi, below
        below = hi
    return None


# -------------------------------------------------------------- process readings


_libc_cache: list[ctypes.CDLL | None] = []


def _libc() -> ctypes.CDLL | None:
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


def _status() -> dict[str, str]:
    try:
        text = Path("/proc/self/status").read_text()
    except OSError:
        return {}
    out = {}
    for line in text.splitlines():
        key, _, value = line.partition(":")
        out[key] = value.strip()
    return out


def _status_kB(key: str) -> int | None:
    value = _status().get(key, "")
    try:
        return int(value.split()[0])
    except (IndexError, ValueError):
        return None


def _has_capability(bit: int) -> bool:
    try:
        return bool(int(_status().get("CapEff", "0"), 16) >> bit & 1)
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


def _cpus_from_sysfs(name: str) -> set[int] | None:
    try:
        return parse_cpu_list(Path(f"/sys/devices/system/cpu/{name}").read_text())
    except (OSError, ValueError):
        return None


def _stack_pointer() -> int | None:
    """This thread's stack pointer at a system call, from /proc/thread-self/syscall.

    The kernel reports the registers of the read() that reads the file: a depth
    like that of a ctypes call, which is what the stack touches must stay below.
    """
    try:
        fields = Path("/proc/thread-self/syscall").read_text().split()
        return int(fields[-2], 16) if len(fields) >= 3 else None
    except (OSError, ValueError):
        return None


def _timer_slack() -> int | None:
    libc = _libc()
    if libc is None:
        return None
    try:
        value = int(libc.prctl(PR_GET_TIMERSLACK, ctypes.c_ulong(0), 0, 0, 0))
    except AttributeError:
        return None
    return value if value >= 0 else None


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
    before = _timer_slack()
    ok = set_timer_slack(TIMER_SLACK_NS)
    after = _timer_slack()
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
        possible = _cpus_from_sysfs("possible")
        online = _cpus_from_sysfs("online") or possible or set(range(os.cpu_count() or 1))
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


class _Mallinfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",
            "usmblks",
            "fsmblks",
            "uordblks",
            "fordblks",
            "keepcost",
        )
    ]


def _pymalloc_note() -> str:
    arena = "1 MiB" if sys.version_info >= (3, 10) and sys.maxsize > 2**32 else "256 kB"
    return (
        f"CPython keeps small objects in its own {arena} arenas, which this does not cover "
        "(mlockall's MCL_FUTURE locks those as they are created)"
    )


def _step_heap(kB: int) -> Applied:
    requested = f"{kB} kB"
    size = kB * 1024
    libc = _libc()
    if libc is None or not hasattr(libc, "mallopt"):
        return Applied(
            "heap_prefault",
            requested,
            False,
            "the C library has no mallopt (not glibc); the heap is faulted in on first use",
        )
    libc.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    libc.mallopt.restype = ctypes.c_int
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.malloc.restype = ctypes.c_void_p
    libc.free.argtypes = [ctypes.c_void_p]
    libc.free.restype = None
    # freed memory stays in the process: no trimming of the heap top, no mmap'd chunks
    if not (libc.mallopt(M_TRIM_THRESHOLD, -1) and libc.mallopt(M_MMAP_MAX, 0)):
        return Applied(
            "heap_prefault",
            requested,
            False,
            "glibc refused mallopt(M_TRIM_THRESHOLD) or mallopt(M_MMAP_MAX); "
            "the heap is faulted in on first use",
        )
    ptr = libc.malloc(size)
    if not ptr:
        return Applied(
            "heap_prefault",
            requested,
            False,
            f"ENOMEM: malloc({size}) failed; lower safe_heap_size_kB or free memory",
        )
    ctypes.memset(ptr, 0, size)  # writes every page, so each is faulted in now
    libc.free(ptr)
    kept = ""
    if hasattr(libc, "mallinfo2"):
        libc.mallinfo2.argtypes = []
        libc.mallinfo2.restype = _Mallinfo2
        info = libc.mallinfo2()
        if info.fordblks < size:
            return Applied(
                "heap_prefault",
                requested,
                False,
                f"touched {kB} kB but glibc keeps only {info.fordblks // 1024} kB free for "
                "reuse; the rest went back to the system",
            )
        kept = f"; glibc heap is {info.arena // 1024} kB, {info.fordblks // 1024} kB free for reuse"
    return Applied(
        "heap_prefault",
        requested,
        True,
        f"touched {kB} kB and gave it back to glibc, which keeps it (trimming and mmap'd "
        f"chunks off){kept}; {_pymalloc_note()}",
    )


def _step_stack(kB: int) -> Applied:
    requested = f"{kB} kB"
    if threading.current_thread() is not threading.main_thread():
        return Applied(
            "stack_prefault",
            requested,
            False,
            "not called from the main thread: only the main thread's stack grows on demand "
            "(other threads' stacks are mapped in full; mlockall faults them in)",
        )
    try:
        vma = stack_mapping(Path("/proc/self/maps").read_text())
    except OSError as exc:
        vma = None
        reason = f"cannot read /proc/self/maps ({exc.strerror})"
    else:
        reason = "no [stack] line in /proc/self/maps"
    if vma is None:
        return Applied("stack_prefault", requested, False, reason)
    lo, hi, below = vma
    want = -(-kB * 1024 // PAGE) * PAGE
    # touch only well below the current stack pointer: pages there are not in use
    sp = _stack_pointer()
    first = lo - PAGE
    if sp is not None:
        first = min(first, (sp - STACK_SP_CLEARANCE) // PAGE * PAGE - PAGE)
    last = min(lo - want, first)
    soft, _ = resource.getrlimit(resource.RLIMIT_STACK)
    floor = below + STACK_GUARD_GAP + STACK_MARGIN
    if soft != resource.RLIM_INFINITY:
        floor = max(floor, hi - soft + STACK_MARGIN)
    floor = -(-floor // PAGE) * PAGE
    if first < floor:
        return Applied(
            "stack_prefault",
            requested,
            False,
            f"no room to grow the stack: RLIMIT_STACK is {limit_text(soft, 1024, ' kB')} "
            f"(ulimit -s) and {(hi - lo) // 1024} kB are mapped, {STACK_MARGIN // 1024} kB "
            "kept in reserve; raise ulimit -s",
        )
    short = last < floor
    last = max(last, floor)
    for addr in range(first, last - 1, -PAGE):
        ctypes.memset(addr, 0, 1)  # below the mapping's start: the kernel grows it to here
    after = stack_mapping(Path("/proc/self/maps").read_text())
    new_lo = after[0] if after is not None else lo
    grown_kB = (lo - new_lo) // 1024
    size_kB = (hi - new_lo) // 1024
    if short or grown_kB < kB:
        return Applied(
            "stack_prefault",
            requested,
            False,
            f"grew the stack by {grown_kB} kB only (to {size_kB} kB): RLIMIT_STACK is "
            f"{limit_text(soft, 1024, ' kB')} (ulimit -s) with {STACK_MARGIN // 1024} kB kept "
            "in reserve; raise ulimit -s or lower safe_stack_size_kB",
        )
    return Applied(
        "stack_prefault",
        requested,
        True,
        f"grew the main thread's stack by {grown_kB} kB to {size_kB} kB, faulted in",
    )


def _step_mlockall() -> tuple[Applied, bool]:
    requested = "MCL_CURRENT | MCL_FUTURE"
    libc = _libc()
    if libc is None or not hasattr(libc, "mlockall"):
        return Applied("mlockall", requested, False, "the C library has no mlockall"), False
    libc.mlockall.argtypes = [ctypes.c_int]
    libc.mlockall.restype = ctypes.c_int
    ctypes.set_errno(0)
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        code = ctypes.get_errno()
        memlock, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
        detail = mlockall_refusal(
            code, memlock, _status_kB("VmSize"), _has_capability(CAP_IPC_LOCK)
        )
        return Applied("mlockall", requested, False, f"{detail}; pages may be swapped out"), False
    locked = _status_kB("VmLck")
    amount = "" if locked is None else f"{locked} kB locked (VmLck); "
    return (
        Applied(
            "mlockall",
            requested,
            True,
            f"{amount}memory mapped later is locked as it is mapped",
        ),
        True,
    )


def _step_scheduler(priority: int) -> Applied:
    requested = f"SCHED_FIFO priority {priority}"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        code = exc.errno or 0
        policy = scheduler_name(os.sched_getscheduler(0))
        if code == errno.EPERM:
            rtprio, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
            why = scheduler_refusal(priority, rtprio, os.geteuid(), _has_capability(CAP_SYS_NICE))
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
                items.append(_guarded(name, req, _step_heap, settings.safe_heap_size_kB))
            elif name == "stack_prefault":
                items.append(_guarded(name, req, _step_stack, settings.safe_stack_size_kB))
            elif name == "mlockall":
                result = _guarded(name, req, _step_mlockall)
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
