"""What the channels' memory fences cost: ns per ring and mailbox operation, with the
fences as this CPU needs them and with them forced on.

On x86-64 the channels issue no fence (total store order keeps the stores and loads
in order), so "as this CPU needs" is the real-time path as it runs here, and "forced
on" adds the calls into rtcf._core._atomics that a weakly ordered CPU (ARMv8) makes;
on x86-64 those compile to no instruction, so the difference is the cost of the calls
alone (an ARM CPU adds its dmb). Each operation is timed in alternating rounds of both
settings, in one process, on the same buffers; the table gives the median of the rounds.
"""

from __future__ import annotations

import platform
import statistics
import time
from collections.abc import Callable
from typing import Any

from _common import (
    fmt,
    fmt_ratio,
    machine_info,
    main_guard,
    now_iso,
    parser,
    publish_section,
    table,
    write_results,
)

from rtcf._core import _rings
from rtcf._core._rings import Mailbox, Ring

BATCH = 10_000  # operations per timed call


def _operations() -> dict[str, Callable[[], None]]:
    """Each entry runs BATCH operations of one kind; the ring is drained as it goes."""
    ring = Ring.create(bytearray(Ring.nbytes(1 << 16, 40)), 1 << 16, 40)
    words = ring.data.cast("q")
    record = bytes(40)
    out = bytearray(40)
    mailbox = Mailbox.create(bytearray(Mailbox.nbytes(64)), 64)
    value = bytes(64)
    into = bytearray(64)
    push, pop_into, pending, release = ring.push, ring.pop_into, ring.pending, ring.release
    reserve, commit, push_words = ring.reserve, ring.commit, ring.push_words
    write, try_read = mailbox.write, mailbox.try_read_into
    loop = range(BATCH)

    def ring_push() -> None:
        for _ in loop:
            push(record)
        release(len(ring))

    def ring_reserve_commit() -> None:
        for i in loop:
            offset = reserve()
            words[offset >> 3] = i
            commit()
        release(len(ring))

    def ring_push_words() -> None:
        for i in loop:
            push_words(words, words, i, i, i, i)
        release(len(ring))

    def ring_pop_into() -> None:
        for _ in loop:
            push(record)
        for _ in loop:
            pop_into(out)

    def ring_pending_release() -> None:
        for _ in loop:
            push(record)
        for _ in loop:
            _, n = pending()
            release(1 if n else 0)

    def mailbox_write() -> None:
        for _ in loop:
            write(value)

    def mailbox_read() -> None:
        for _ in loop:
            try_read(into)

    return {
        "ring push (40 B)": ring_push,
        "ring reserve + commit": ring_reserve_commit,
        "ring push_words": ring_push_words,
        "ring push + pop_into": ring_pop_into,
        "ring push + pending/release": ring_pending_release,
        "mailbox write (64 B)": mailbox_write,
        "mailbox try_read_into": mailbox_read,
    }


def _time(fn: Callable[[], None]) -> float:
    t0 = time.perf_counter_ns()
    fn()
    return (time.perf_counter_ns() - t0) / BATCH


def measure(seconds: float) -> dict[str, Any]:
    operations = _operations()
    native = _rings.FENCED
    samples: dict[str, dict[str, list[float]]] = {
        name: {"native": [], "forced": []} for name in operations
    }
    deadline = time.monotonic() + seconds
    rounds = 0
    while rounds < 5 or time.monotonic() < deadline:
        for name, fn in operations.items():
            for setting in ("native", "forced"):
                _rings.FENCED = native if setting == "native" else True
                samples[name][setting].append(_time(fn))
        rounds += 1
    _rings.FENCED = native
    return {
        "rounds": rounds,
        "native_fences": native,
        "ns_per_op": {
            name: {s: statistics.median(v) for s, v in by.items()} for name, by in samples.items()
        },
    }


def main() -> int:
    args = parser(__doc__.splitlines()[0], default_duration=20.0).parse_args()
    seconds = args.duration if args.duration is not None else (2.0 if args.quick else 20.0)
    machine = machine_info()
    result = measure(seconds)
    native = "fences" if result["native_fences"] else "no fences"
    rows = [
        [name, fmt(v["native"]), fmt(v["forced"]), fmt_ratio(v["forced"] / v["native"])]
        for name, v in result["ns_per_op"].items()
    ]
    needs = f"ns, as {platform.machine()} needs ({native})"
    text = table(["operation", needs, "ns, fences forced", "ratio"], rows)
    print(text)
    timestamp = now_iso()
    write_results(
        "channels",
        {"machine": machine, "timestamp": timestamp, "seconds": seconds, **result},
        args.quick,
    )
    if not args.quick:
        intro = (
            f"Median of {result['rounds']} alternating rounds of {BATCH} operations each "
            f"(`benchmarks/channels.py`)."
        )
        publish_section("channels", [intro, text], machine, timestamp)
    return 0


if __name__ == "__main__":
    main_guard(main)
