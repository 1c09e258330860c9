"""Shared-memory channels between real processes, at full speed on both sides.

The child process runs ``sys.executable -c <code>``; the test process is the other
side. Each test creates its segments itself and hands them to the child as inherited
file descriptors (anonymous memory: nothing has a name in /dev/shm). The ring, byte
ring and mailbox tests run twice on x86: as the CPU needs them (no fences) and with the fences
that weakly ordered CPUs need forced on (RTCF_FENCES=1, in both processes);
scripts/test-aarch64 runs them on arm64 under QEMU, with RTCF_CHANNEL_TEST_N records.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from contextlib import contextmanager
from itertools import pairwise
from pathlib import Path

import pytest

from rtcf._core import _rings
from rtcf._core._byte_rings import ByteRing, record_bytes
from rtcf._core._rings import Mailbox, Ring
from rtcf._runtime._shm import Segment

from .._proc import rtcf_shm_names
from .conftest import SRC

pytestmark = pytest.mark.integration

# fewer under emulation (scripts/test-aarch64), where each record takes ~20x longer
N = int(os.environ.get("RTCF_CHANNEL_TEST_N", "1000000"))
DEADLINE_S = 60.0  # a hang fails the test instead of blocking the run

# Words of the control line at the start of each test segment.
DONE, STARTED, ELAPSED_NS, FENCED = 0, 1, 2, 3

# f(seq) of the records; the same expression is in the producer's code.
PATTERN = "(seq * 0x9E3779B1) ^ 0x5A5A5A5A"


def pattern(seq: int) -> int:
    return (seq * 0x9E3779B1) ^ 0x5A5A5A5A


PREAMBLE = """
import sys, time
from rtcf._core import _rings
from rtcf._core._byte_rings import ByteRing, record_bytes
from rtcf._core._rings import Mailbox, Ring
from rtcf._runtime._shm import Segment
N = int(sys.argv[2])
seg = Segment.from_fd(int(sys.argv[1]))
ctl = seg.buf[:64].cast("q")
"""

EPILOGUE = """
ctl[ELAPSED_NS] = int((time.perf_counter() - t0) * 1e9)
ctl[FENCED] = int(_rings.FENCED)
ctl[DONE] = 1  # after the last commit or write: the other side may stop once empty
"""

PRODUCE_RESERVE_COMMIT = f"""
ring = Ring.open(seg.buf[64:])
words = ring.data.cast("q")
reserve, commit = ring.reserve, ring.commit
ctl[STARTED] = 1
t0 = time.perf_counter()
for seq in range(N):
    offset = reserve()
    if offset < 0:
        continue  # dropped: the ring counts it
    i = offset >> 3
    v = {PATTERN}
    words[i + 1] = v
    words[i + 2] = v
    words[i + 3] = v
    words[i + 4] = v
    words[i] = seq
    commit()
{EPILOGUE}
words.release()
ring.close()
"""

PRODUCE_PUSH = f"""
import struct
ring = Ring.open(seg.buf[64:])
pack, push = struct.Struct("5q").pack, ring.push
ctl[STARTED] = 1
t0 = time.perf_counter()
for seq in range(N):
    v = {PATTERN}
    push(pack(seq, v, v, v, v))
{EPILOGUE}
ring.close()
"""

WRITE_MAILBOX = f"""
box = Mailbox.open(seg.buf[64:])
write = box.write
ctl[STARTED] = 1
t0 = time.perf_counter()
for value in range(1, N + 1):
    write(value.to_bytes(8, "little") * 32)
{EPILOGUE}
box.close()
"""

CLOSE = """
ctl.release()
seg.close()
"""


def child_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    return env


def start(code: str, *args: object) -> subprocess.Popen[str]:
    """Run ``code`` in a child; a Segment among ``args`` is passed as its inherited fd."""
    consts = f"DONE, STARTED, ELAPSED_NS, FENCED = {DONE}, {STARTED}, {ELAPSED_NS}, {FENCED}\n"
    fds = tuple(a.fd for a in args if isinstance(a, Segment))
    argv = [str(a.fd) if isinstance(a, Segment) else str(a) for a in args]
    return subprocess.Popen(
        [sys.executable, "-c", consts + textwrap.dedent(code), *argv],
        pass_fds=fds,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(),
    )


def finish(proc: subprocess.Popen[str], stdin: str | None = None) -> str:
    out, err = proc.communicate(stdin, timeout=DEADLINE_S)
    assert proc.returncode == 0, f"child failed ({proc.returncode}):\n{err}"
    assert err == "", err
    return out


@contextmanager
def segment(size: int) -> Iterator[Segment]:
    seg = Segment.create(size)
    try:
        yield seg
    finally:
        seg.close()
    assert rtcf_shm_names() == []


@contextmanager
def child(code: str, *args: object) -> Iterator[subprocess.Popen[str]]:
    proc = start(code, *args)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    assert rtcf_shm_names() == []


@pytest.fixture(
    params=["native", "forced"] if _rings.TOTAL_STORE_ORDER else ["native"],
    ids=lambda mode: f"fences-{mode}",
)
def fences(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Fences as this CPU needs them, or forced on in this process and the child."""
    if request.param == "forced":
        monkeypatch.setenv("RTCF_FENCES", "1")
        monkeypatch.setattr(_rings, "FENCED", True)
    return str(request.param)


def check_alive(proc: subprocess.Popen[str], t_end: float) -> None:
    if proc.poll() is not None:
        _, err = proc.communicate()
        pytest.fail(f"child exited early ({proc.returncode}):\n{err}")
    if time.monotonic() > t_end:
        pytest.fail("timed out")


def consume(
    ring: Ring, ctl: memoryview, proc: subprocess.Popen[str]
) -> tuple[list[int], list[tuple[int, ...]]]:
    """Drain ``ring`` in place until the producer is done; (sequence numbers, torn)."""
    received: list[int] = []
    torn: list[tuple[int, ...]] = []
    append = received.append
    words = ring.data.cast("q")
    width = ring.record_size // 8
    pending, release = ring.pending, ring.release
    t_end = time.monotonic() + DEADLINE_S
    try:
        while True:
            slot, n = pending()
            if n:
                for i in range(slot * width, (slot + n) * width, width):
                    seq = words[i]
                    v = pattern(seq)
                    if not (words[i + 1] == words[i + 2] == words[i + 3] == words[i + 4] == v):
                        torn.append(tuple(words[i : i + 5]))
                    append(seq)
                release(n)
            elif ctl[DONE]:
                if not len(ring):  # read after DONE: every commit is visible
                    return received, torn
            else:
                check_alive(proc, t_end)
    finally:
        words.release()


@pytest.mark.parametrize(
    ("capacity", "producer"),
    [
        pytest.param(1024, PRODUCE_RESERVE_COMMIT, id="small-ring-reserve-commit"),
        pytest.param(1024, PRODUCE_PUSH, id="small-ring-push"),
        pytest.param(2**20, PRODUCE_RESERVE_COMMIT, id="big-ring-reserve-commit"),
        pytest.param(2**20, PRODUCE_PUSH, id="big-ring-push"),
    ],
)
def test_ring_between_processes(capacity: int, producer: str, fences: str) -> None:
    with (
        segment(64 + Ring.nbytes(capacity, 40)) as seg,
        seg.buf[:64].cast("q") as ctl,
        Ring.create(seg.buf[64:], capacity, 40) as ring,
    ):
        t0 = time.perf_counter()
        with child(PREAMBLE + producer + CLOSE, seg, N) as proc:
            received, torn = consume(ring, ctl, proc)
            elapsed = time.perf_counter() - t0
            finish(proc)
        dropped = ring.dropped
        produce_s = ctl[ELAPSED_NS] / 1e9
        child_fenced = ctl[FENCED]

    print(
        f"\nring {capacity}: producer {N / produce_s:,.0f} records/s; "
        f"received {len(received):,} ({len(received) / elapsed:,.0f}/s end to end), "
        f"dropped {dropped:,}"
    )
    assert child_fenced == _rings.FENCED == (fences == "forced" or not _rings.TOTAL_STORE_ORDER)
    assert torn == []
    assert all(a < b for a, b in pairwise(received))
    assert len(received) + dropped == N
    if dropped:
        gaps = received[0] + (N - 1 - received[-1])
        gaps += sum(b - a - 1 for a, b in pairwise(received))
        assert gaps == dropped
    if capacity >= N:
        assert dropped == 0
        assert received == list(range(N))


# A ByteRing's records: the sequence number, then whole words of the pattern, then a
# tail of 0..7 bytes: 8 to 60 bytes, so that records pad, wrap and fill the ring unevenly.
LENGTH = "8 + 8 * (seq % 7) + seq % 5"


def length(seq: int) -> int:
    return 8 + 8 * (seq % 7) + seq % 5


TAILS = [b"\xa5" * r for r in range(8)]

PRODUCE_BYTES_RESERVE_COMMIT = f"""
from rtcf._core._byte_rings import ByteRing
ring = ByteRing.open(seg.buf[64:])
words, data = ring.words, ring.data
reserve, commit = ring.reserve, ring.commit
tails = [b"\\xa5" * r for r in range(8)]
ctl[STARTED] = 1
t0 = time.perf_counter()
for seq in range(N):
    n = {LENGTH}
    at = reserve(n)
    if at < 0:
        continue  # dropped: the ring counts it
    i = at >> 3
    v = {PATTERN}
    words[i] = seq
    for k in range(i + 1, i + (n >> 3)):
        words[k] = v
    whole = at + (n & ~7)
    data[whole : at + n] = tails[n & 7]
    commit()
{EPILOGUE}
ring.close()
"""

PRODUCE_BYTES_PUSH = f"""
import struct
from rtcf._core._byte_rings import ByteRing
ring = ByteRing.open(seg.buf[64:])
push = ring.push
tails = [b"\\xa5" * r for r in range(8)]
ctl[STARTED] = 1
t0 = time.perf_counter()
for seq in range(N):
    n = {LENGTH}
    v = {PATTERN}
    push(struct.pack(f"{{n >> 3}}q", seq, *([v] * ((n >> 3) - 1))) + tails[n & 7])
{EPILOGUE}
ring.close()
"""


def consume_bytes(
    ring: ByteRing, ctl: memoryview, proc: subprocess.Popen[str]
) -> tuple[list[int], list[tuple[int, ...]]]:
    """Drain ``ring`` in place until the producer is done; (sequence numbers, torn)."""
    received: list[int] = []
    torn: list[tuple[int, ...]] = []
    append = received.append
    words, data = ring.words, ring.data
    pending, record_at, release_to = ring.pending, ring.record_at, ring.release_to
    t_end = time.monotonic() + DEADLINE_S
    while True:
        position, head = pending()
        if position < head:
            while position < head:
                off, n, position = record_at(position)
                i = off >> 3
                seq = words[i]
                v = pattern(seq)
                whole = n >> 3
                if (
                    n != length(seq)
                    or any(words[k] != v for k in range(i + 1, i + whole))
                    or data[off + 8 * whole : off + n] != TAILS[n & 7]
                ):
                    torn.append((seq, n, *words[i : i + whole]))
                append(seq)
            release_to(position)
        elif ctl[DONE]:
            if not len(ring):  # read after DONE: every commit is visible
                return received, torn
        else:
            check_alive(proc, t_end)


@pytest.mark.parametrize(
    ("size", "producer"),
    [
        pytest.param(4096, PRODUCE_BYTES_RESERVE_COMMIT, id="small-ring-reserve-commit"),
        pytest.param(4096, PRODUCE_BYTES_PUSH, id="small-ring-push"),
        pytest.param(2**26, PRODUCE_BYTES_RESERVE_COMMIT, id="big-ring-reserve-commit"),
    ],
)
def test_byte_ring_between_processes(size: int, producer: str, fences: str) -> None:
    with (
        segment(64 + ByteRing.nbytes(size)) as seg,
        seg.buf[:64].cast("q") as ctl,
        ByteRing.create(seg.buf[64:], size) as ring,
    ):
        t0 = time.perf_counter()
        with child(PREAMBLE + producer + CLOSE, seg, N) as proc:
            received, torn = consume_bytes(ring, ctl, proc)
            elapsed = time.perf_counter() - t0
            finish(proc)
        dropped = ring.dropped
        produce_s = ctl[ELAPSED_NS] / 1e9
        child_fenced = ctl[FENCED]

    print(
        f"\nbyte ring {size}: producer {N / produce_s:,.0f} records/s; "
        f"received {len(received):,} ({len(received) / elapsed:,.0f}/s end to end), "
        f"dropped {dropped:,}"
    )
    assert child_fenced == _rings.FENCED == (fences == "forced" or not _rings.TOTAL_STORE_ORDER)
    assert torn == []
    assert all(a < b for a, b in pairwise(received))
    assert len(received) + dropped == N
    if dropped:
        gaps = received[0] + (N - 1 - received[-1])
        gaps += sum(b - a - 1 for a, b in pairwise(received))
        assert gaps == dropped
    if sum(record_bytes(length(seq)) for seq in range(N)) <= size:
        assert dropped == 0
        assert received == list(range(N))


def test_mailbox_between_processes(fences: str) -> None:
    size = 256
    final = (N).to_bytes(8, "little") * 32
    with (
        segment(64 + Mailbox.nbytes(size)) as seg,
        seg.buf[:64].cast("q") as ctl,
        Mailbox.create(seg.buf[64:], size) as box,
    ):
        out = bytearray(size)
        try_read_into = box.try_read_into
        reads = changed = never = 0
        torn: list[bytes] = []
        backwards: list[tuple[int, int]] = []
        last = 0
        with child(PREAMBLE + WRITE_MAILBOX + CLOSE, seg, N) as proc:
            t_end = time.monotonic() + DEADLINE_S
            while last != N:
                n = try_read_into(out)
                reads += 1
                if n == -2:
                    changed += 1
                    continue
                if n == -1:
                    never += 1
                    check_alive(proc, t_end)
                    continue
                head = out[:8]
                if n != size or out != head * 32:
                    torn.append(bytes(out))
                value = int.from_bytes(head, "little")
                if value < last:
                    backwards.append((last, value))
                last = value
                if reads & 0xFFFF == 0:
                    check_alive(proc, t_end)
            finish(proc)
        after = box.read()
        version = box.version
        write_s = ctl[ELAPSED_NS] / 1e9
        child_fenced = ctl[FENCED]

    print(
        f"\nmailbox: writer {N / write_s:,.0f} writes/s; reader {reads:,} attempts, "
        f"{changed:,} changed during the copy (-2), {never:,} before the first write"
    )
    assert child_fenced == _rings.FENCED == (fences == "forced" or not _rings.TOTAL_STORE_ORDER)
    assert torn == []
    assert backwards == []
    assert last == N
    assert after == final
    assert version == N


SEGMENT_PEER = """
import sys
from rtcf._runtime._shm import Segment
seg = Segment.from_fd(int(sys.argv[1]), "rtcf-test")
print(seg.size, seg.buf[:5].tobytes().decode(), flush=True)
sys.stdin.readline()
seg.buf[5:10] = b"world"
seg.close()
print("done", flush=True)
"""


def test_segment_created_by_one_process_mapped_by_another() -> None:
    with segment(10000) as seg:
        seg.buf[:5] = b"hello"
        assert os.readlink(f"/proc/self/fd/{seg.fd}").startswith("/memfd:rtcf")
        with child(SEGMENT_PEER, seg) as proc:
            assert proc.stdout is not None
            assert proc.stdout.readline().split() == ["12288", "hello"]
            assert finish(proc, "go\n") == "done\n"
        assert seg.buf[5:10] == b"world"
        assert rtcf_shm_names() == []


SEGMENT_CREATOR = """
import os, sys
from rtcf._runtime._shm import Segment
segs = [Segment.create(3 << 20, "rtcf-test") for _ in range(4)]
print(os.getpid(), flush=True)
sys.stdin.readline()
"""


def test_a_creator_killed_with_sigkill_leaves_nothing_behind() -> None:
    with child(SEGMENT_CREATOR) as proc:
        assert proc.stdout is not None
        pid = int(proc.stdout.readline())
        maps = Path(f"/proc/{pid}/maps").read_text()
        assert maps.count("/memfd:rtcf-test (deleted)") == 4  # mapped, and never had a name
        assert "/dev/shm/" not in maps
        links = [os.readlink(f) for f in Path(f"/proc/{pid}/fd").iterdir()]
        assert sum(link.startswith("/memfd:rtcf-test") for link in links) >= 4
        proc.kill()
        proc.wait()
    assert rtcf_shm_names() == []
