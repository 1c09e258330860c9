"""Keeping the worker's memory resident: heap and stack pre-faulted, then mlockall.

A page fault in the loop costs microseconds (a minor fault) to milliseconds (a
page read back from swap). So before the loop starts, the heap and the main
thread's stack are touched to the sizes the settings ask for, and mlockall then
locks what is mapped and whatever is mapped later. Each step returns an
:class:`Applied` that says what took effect, or why not and what to change.
"""

from __future__ import annotations

import ctypes
import errno
import mmap
import os
import resource
import sys
import threading
from pathlib import Path

from ._kernel_facts import c_library, errno_name, has_capability, limit_text, status_kB
from ._realtime_report import Applied

PAGE = mmap.PAGESIZE
STACK_MARGIN = 256 * 1024  # kept free below RLIMIT_STACK
STACK_GUARD_GAP = 1024 * 1024  # the kernel's default stack_guard_gap (256 pages)
STACK_SP_CLEARANCE = 64 * 1024  # never touch closer than this below the stack pointer

M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
MCL_CURRENT = 1
MCL_FUTURE = 2
CAP_IPC_LOCK = 14


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


def step_heap(kB: int) -> Applied:
    requested = f"{kB} kB"
    size = kB * 1024
    libc = c_library()
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


def step_stack(kB: int) -> Applied:
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


def step_mlockall() -> tuple[Applied, bool]:
    requested = "MCL_CURRENT | MCL_FUTURE"
    libc = c_library()
    if libc is None or not hasattr(libc, "mlockall"):
        return Applied("mlockall", requested, False, "the C library has no mlockall"), False
    libc.mlockall.argtypes = [ctypes.c_int]
    libc.mlockall.restype = ctypes.c_int
    ctypes.set_errno(0)
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        code = ctypes.get_errno()
        memlock, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
        detail = mlockall_refusal(
            code, memlock, status_kB("VmSize"), has_capability(CAP_IPC_LOCK)
        )
        return Applied("mlockall", requested, False, f"{detail}; pages may be swapped out"), False
    locked = status_kB("VmLck")
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
