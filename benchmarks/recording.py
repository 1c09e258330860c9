"""What recording a port costs (rtcf launch --record): ns per recorded write, ns per
record drained, and how many records a topic's ring holds before it drops.

In one process, on this process's hot path (compiled unless RTCF_PURE_PYTHON=1): one
output per kind of value, written BATCH times with the same value, not recorded and then
recorded (the tap: a word ring's four stores for a float; for a float array or a string
its bytes encoded into the topic's ring), the ring drained between the timed batches as
the supervisor does on the other core; alternating rounds, the median of each. "Records
a ring holds" fills one topic's ring without draining it: at 1 kHz, that many
milliseconds of a stalled supervisor lose nothing.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from _common import (
    fmt,
    machine_info,
    main_guard,
    now_iso,
    parser,
    publish_section,
    table,
    write_results,
)

import rtcf
from rtcf._core import _hotpath
from rtcf._runtime._recording import (
    RecordingDrain,
    WorkerRecording,
    recorded_topics,
    segment_size,
)

BATCH = 64  # writes per timed call: no more than any topic's ring holds, before the byte
# rings too (nothing is dropped: a drop is cheaper than a push, and would flatter the cost)


def _kinds() -> dict[str, tuple[type, Any]]:
    import numpy as np

    return {
        "float": (float, 0.5),
        "float array, 3 elements": (np.ndarray, np.array([1.0, 2.0, 3.0])),
        "float array, 100 elements": (np.ndarray, np.linspace(0.0, 1.0, 100)),
        "str, 16 characters": (str, "iteration 123456"),
    }


class _Writer(rtcf.Component):
    """One output of the kind the benchmark gives it."""

    kind: type = float

    def configure(self) -> None:
        self.out = self.add_output("x", self.kind)


class _Recorded:
    """One output, its topic's ring in a bytearray, the tap installed or not."""

    def __init__(self, cls: type) -> None:
        writer = type("Writer", (_Writer,), {"kind": cls})()
        writer.configure()
        self.port = writer.out
        self.topics = recorded_topics([self.port], [], ".*")
        # every page touched first, as the worker's locked segment is: a ring that moves
        # through its memory would otherwise pay the page faults in the timed writes
        self.buf = memoryview(bytearray(b"\xff") * segment_size(self.topics))
        self.drain = RecordingDrain(self.buf, self.topics)
        self.state = writer._rtcf_state
        self.taps: WorkerRecording | None = None

    def record(self, on: bool) -> None:
        if on and self.taps is None:
            self.taps = WorkerRecording(self.buf, self.topics, [self.port], [], self.state,
                                        wait=False)
        elif not on and self.taps is not None:
            self.taps.release()
            self.taps = None

    def empty(self) -> int:
        return self.drain.drain(lambda r: None)

    def close(self) -> None:
        self.record(False)
        self.drain.close()


class _FixedRecords:
    """The same output recorded as before the byte rings: a Ring of records of the
    type's worst case (24 + 64 KiB), the tap's reserve, three word stores, the copy and
    the commit (its code as it was), for a side-by-side row in the same run."""

    def __init__(self, cls: type) -> None:
        from rtcf._core._rings import Ring
        from rtcf._runtime._codec import codec_for

        codec = codec_for(cls)
        assert codec is not None
        size = 24 + codec.max_size
        self.ring = Ring.create(bytearray(b"\xff") * Ring.nbytes(64, size), 64, size)
        self.words = self.ring.data.cast("q")
        self.encode = codec.encode

    def writes(self, value: Any, batch: int, state: Any) -> Callable[[], None]:
        ring, words, data, encode = self.ring, self.words, self.ring.data, self.encode
        loop = range(batch)

        def tap(value: Any) -> None:  # what a port's write called, less the write
            payload = encode(value)
            n = len(payload)
            off = ring.reserve()
            if off < 0:
                return
            w = off >> 3
            words[w] = n
            words[w + 1] = state.iteration
            words[w + 2] = state.stamp_ns
            data[off + 24 : off + 24 + n] = payload
            ring.commit()

        def run() -> None:
            for _ in loop:
                tap(value)
            ring.release(len(ring))

        return run

    def close(self) -> None:
        self.words.release()
        self.ring.close()


def _timed(fn: Callable[[], None], batch: int) -> float:
    t0 = time.perf_counter_ns()
    fn()
    return (time.perf_counter_ns() - t0) / batch


def _writes(port: Any, value: Any, batch: int) -> Callable[[], None]:
    write = port.write
    loop = range(batch)

    def run() -> None:
        for _ in loop:
            write(value)

    return run


def _held(cls: type, value: Any) -> int:
    """Records one topic's ring takes before its first drop."""
    rec = _Recorded(cls)
    try:
        rec.record(True)
        write = rec.port.write
        n = 0
        while not rec.drain.dropped() and n < 1 << 20:
            write(value)
            n += 1
        return n - 1 if rec.drain.dropped() else n
    finally:
        rec.close()


def measure(seconds: float) -> dict[str, Any]:
    rows: dict[str, Any] = {}
    for name, (cls, value) in _kinds().items():
        held = _held(cls, value)
        batch = min(BATCH, held)
        rec = _Recorded(cls)
        try:
            run = _writes(rec.port, value, batch)
            plain: list[float] = []
            recorded: list[float] = []
            fixed = _FixedRecords(cls) if cls is not float else None
            fixed_run = None if fixed is None else fixed.writes(value, batch, rec.state)
            before: list[float] = []
            drained: list[float] = []
            dropped = 0
            deadline = time.monotonic() + seconds / len(_kinds())
            rounds = 0
            while rounds < 5 or time.monotonic() < deadline:
                rec.record(False)
                plain.append(_timed(run, batch))
                rec.record(True)
                recorded.append(_timed(run, batch))
                if fixed_run is not None:
                    before.append(_timed(fixed_run, batch))
                t0 = time.perf_counter_ns()
                got = rec.empty()
                drained.append((time.perf_counter_ns() - t0) / max(1, got))
                dropped += batch - got
                rounds += 1
            rows[name] = {
                "rounds": rounds,
                "batch": batch,
                "write_ns": statistics.median(plain),
                "recorded_write_ns": statistics.median(recorded),
                "cost_per_record_ns": statistics.median(recorded) - statistics.median(plain),
                "drain_per_record_ns": statistics.median(drained),
                "dropped": dropped,
                "fixed_records_cost_ns": statistics.median(before) if before else None,
            }
        finally:
            rec.close()
            if fixed is not None:
                fixed.close()
        rows[name]["records_a_ring_holds"] = held
    return {"hot_path": _hotpath.describe(), "kinds": rows}


def main() -> int:
    args = parser(__doc__.splitlines()[0], default_duration=20.0).parse_args()
    seconds = args.duration if args.duration is not None else (2.0 if args.quick else 20.0)
    machine = machine_info()
    result = measure(seconds)
    rows = [
        [name, fmt(v["write_ns"], 0), fmt(v["recorded_write_ns"], 0),
         fmt(v["cost_per_record_ns"], 0), fmt(v["fixed_records_cost_ns"], 0),
         fmt(v["drain_per_record_ns"], 0),
         str(v["records_a_ring_holds"]), str(v["dropped"])]
        for name, v in result["kinds"].items()
    ]
    text = table(
        ["value written", "write, ns", "recorded write, ns", "recording, ns per record",
         "the same in 64 KiB records (before)", "drain, ns per record",
         "records a ring holds", "dropped"],
        rows,
    )
    print(f"hot path: {result['hot_path']}")
    print(text)
    timestamp = now_iso()
    write_results(
        "recording",
        {"machine": machine, "timestamp": timestamp, "seconds": seconds, **result},
        args.quick,
    )
    if not args.quick:
        intro = (
            f"Median of alternating rounds of {BATCH} writes each, in one process, hot path "
            f"{result['hot_path']} (`benchmarks/recording.py`)."
        )
        publish_section("recording", [intro, text], machine, timestamp)
    return 0


if __name__ == "__main__":
    main_guard(main)
