"""The recording's rings: taps on outputs, drops counted, records read back in order."""

from __future__ import annotations

import struct

import rtcf
from rtcf._runtime._codec import codec_for
from rtcf._runtime._mcap import McapRecording
from rtcf._runtime._recording import (
    RecordingDrain,
    WorkerRecording,
    recorded_topics,
    segment_size,
)


class Writer(rtcf.Component):
    def configure(self) -> None:
        self.out = self.add_output("x", float)
        self.other = self.add_output("y", int)


def _setup(wait: bool = False):
    comp = Writer()
    comp.configure()
    ports = [comp.out, comp.other]
    topics = recorded_topics(ports, [], "/x")
    buf = memoryview(bytearray(segment_size(topics)))
    drain = RecordingDrain(buf, topics)
    recording = WorkerRecording(buf, topics, ports, [], comp._rtcf_state, wait=wait)
    return comp, topics, drain, recording


def test_only_the_selected_topics_are_tapped_and_records_carry_the_iteration() -> None:
    comp, topics, drain, recording = _setup()
    assert [t.topic for t in topics] == ["/x"]
    state = comp._rtcf_state
    for i in range(5):
        state.iteration, state.stamp_ns = i, 1000 * i
        comp.out.write(i * 1.5)
        comp.other.write(i)  # not recorded
    got = []
    assert drain.drain(got.append) == 5
    assert [(r.iteration, r.stamp_ns) for r in got] == [(i, 1000 * i) for i in range(5)]
    assert [struct.unpack("<d", r.payload)[0] for r in got] == [i * 1.5 for i in range(5)]
    assert comp.out._slot.value == 6.0  # the write itself still happened
    recording.release()
    assert type(comp.out) is rtcf.OutputPort  # the tap is gone after the run
    drain.close()


def test_a_full_ring_drops_and_counts_every_record_it_could_not_take() -> None:
    comp, topics, drain, recording = _setup()
    capacity = topics[0].capacity
    for i in range(capacity + 7):
        comp.out.write(float(i))
    assert drain.dropped() == {"/x": 7}
    got = []
    drain.drain(got.append)
    assert len(got) == capacity  # the first ones: the newest found the ring full
    assert struct.unpack("<d", got[-1].payload)[0] == capacity - 1
    recording.release()
    drain.close()


def test_the_summary_names_what_was_dropped(tmp_path) -> None:
    rec = McapRecording(str(tmp_path / "r.mcap"))
    rec.messages = {"/x": 10}
    rec.end_run({"/x": 3}, {"/s": {"dropped": 0, "oversize": 2}})
    assert rec.summary() == (
        f"recorded 10 messages on 1 topics into {tmp_path / 'r.mcap'}; dropped: 5 "
        "(/x 3 (ring full), /s 2 (too large))"
    )


class Arrays(rtcf.Component):
    def configure(self) -> None:
        import numpy as np

        self.np = np
        self.out = self.add_output("a", np.ndarray)


def test_a_float_array_record_takes_its_own_size_and_the_tap_keeps_no_memory() -> None:
    import gc
    import sys
    import tracemalloc

    comp = Arrays()
    comp.configure()
    topics = recorded_topics([comp.out], [], ".*")
    assert topics[0].byte_ring and topics[0].capacity == 4 << 20
    buf = memoryview(bytearray(segment_size(topics)))
    drain = RecordingDrain(buf, topics)
    recording = WorkerRecording(buf, topics, [comp.out], [], comp._rtcf_state, wait=False)
    state = comp._rtcf_state
    value = comp.np.array([1.0, 2.0, 3.0])
    write = comp.out.write
    # 48 bytes a record (length, iteration, stamp, three floats): 87,381 of them fit
    tap = recording.taps["/a"]
    n = 0
    while not tap.dropped:
        state.iteration = n
        write(value)
        n += 1
    assert n - 1 == (4 << 20) // 48
    got = []
    drain.drain(got.append)
    assert len(got) == n - 1 and got[-1].iteration == n - 2
    assert got[7].payload == value.tobytes()

    def rounds(k: int) -> None:
        for _ in range(k):
            for _ in range(1000):
                write(value)
            drain.drain(lambda r: None)

    rounds(3)
    gc.collect()
    before = sys.getallocatedblocks()
    rounds(20)
    gc.collect()
    assert sys.getallocatedblocks() - before < 100  # 20,000 records kept nothing
    encode = codec_for(comp.np.ndarray).encode

    def peak(fn) -> int:
        """The median of 200 calls of the most memory a call held at once."""
        tracemalloc.start()
        try:
            peaks = []
            for i in range(200):
                state.iteration, state.stamp_ns = 100_000 + i, 10**15 + i  # not cached ints
                now, _ = tracemalloc.get_traced_memory()
                tracemalloc.reset_peak()
                fn()
                peaks.append(tracemalloc.get_traced_memory()[1] - now)
                drain.drain(lambda r: None)
        finally:
            tracemalloc.stop()
        return sorted(peaks)[len(peaks) // 2]

    # a recorded write holds the codec's bytes of the value and, for a moment, the
    # numbers of the ring's arithmetic (Python ints): the same for a value of 3 floats
    # or of 1000, so nothing of the record's size
    beyond = []
    for value in (comp.np.array([1.0, 2.0, 3.0]), comp.np.linspace(0.0, 1.0, 1000)):
        codec = peak(lambda v=value: encode(v))
        recorded = peak(lambda v=value: write(v))
        print(f"peak allocated: {codec} B by the codec, {recorded} B by a recorded write")
        beyond.append(recorded - codec)
    assert abs(beyond[0] - beyond[1]) < 256 and max(beyond) < 512, beyond
    recording.release()
    drain.close()
