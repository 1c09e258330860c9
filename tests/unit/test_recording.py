"""The recording's rings: taps on outputs, drops counted, records read back in order."""

from __future__ import annotations

import struct

import rtcf
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
