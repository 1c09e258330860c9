"""Both ends of a run's port channels, in one process (the worker's and the supervisor's)."""

from contextlib import contextmanager

import pytest

from rtcf._core._ports import InputPort, OutputPort
from rtcf._core._rings import Mailbox, Ring
from rtcf._runtime._codec import codec_for
from rtcf._runtime._doorbell import Doorbell
from rtcf._runtime._port_channels import (
    OUTPUT_RING_RECORDS,
    WorkerPorts,
    mapped_ports,
    read_record,
    segment_size,
)


def _ports():
    out = OutputPort("/a", "out", float)
    out.topic = "/ros/out"
    inp = InputPort("/b", "in", float)
    inp.topic = "/ros/in"
    return out, inp


def _supervisor_side(buf, ports):
    channels = {}
    for p in ports:
        view = buf[p.offset : p.offset + p.nbytes]
        if p.direction == "output":
            channels[p.topic] = Ring.create(view, OUTPUT_RING_RECORDS, 8 + p.max_size)
        else:
            channels[p.topic] = Mailbox.create(view, p.max_size)
        view.release()
    return channels


@contextmanager
def _both_ends(outputs, inputs, doorbell=None, arrived=None):
    """A run's port channels: the worker's WorkerPorts and the supervisor's channels by
    topic, released on the way out (the worker's first). ``arrived``: messages by topic
    that the supervisor's side writes before the worker sets up its run."""
    ports = mapped_ports(outputs, inputs)
    buf = memoryview(bytearray(segment_size(ports)))
    channels = _supervisor_side(buf, ports)
    for topic, message in (arrived or {}).items():
        channels[topic].write(message)
    worker = WorkerPorts(buf, ports, outputs, inputs, doorbell=doorbell)
    try:
        yield worker, channels
    finally:
        worker.release()
        for channel in channels.values():
            channel.close()


def test_writes_push_records_and_the_doorbell_rings_once_after_the_iteration():
    out, inp = _ports()
    bell = Doorbell.create()
    try:
        with _both_ends([out], [inp], doorbell=bell) as (worker, channels):
            worker.ring_if_pushed()  # nothing written: no ring
            assert bell.wait(0.0) is False
            out.write(2.5)
            out.write(3.5)
            assert bell.wait(0.0) is False  # not during the iteration
            worker.ring_if_pushed()
            assert bell.wait(1.0) is True
            ring = channels["/ros/out"]
            start, n = ring.pending()
            assert n == 2
            assert codec_for(float).decode(read_record(ring, start)) == 2.5
            assert codec_for(float).decode(read_record(ring, start + 1)) == 3.5
            ring.release(n)
            worker.ring_if_pushed()  # rung once per iteration that wrote
            assert bell.wait(0.0) is False
    finally:
        bell.close()
    assert type(out) is OutputPort  # the tap is gone with the run


def test_a_full_output_ring_counts_the_drop_and_keeps_the_first_records():
    out, _ = _ports()
    with _both_ends([out], []) as (_, channels):
        for i in range(OUTPUT_RING_RECORDS + 5):
            out.write(float(i))
        ring = channels["/ros/out"]
        start, n = ring.pending()
        assert n == OUTPUT_RING_RECORDS
        assert ring.dropped == 5
        assert codec_for(float).decode(read_record(ring, start)) == 0.0
        ring.release(n)


def test_a_fed_input_reads_the_newest_message_of_its_mailbox():
    _, inp = _ports()
    with _both_ends([], [inp]) as (worker, channels):
        (feeder,) = worker.feeders
        feeder()
        assert inp.read() is None
        box = channels["/ros/in"]
        box.write(codec_for(float).encode(1.0))
        box.write(codec_for(float).encode(7.0))
        feeder()
        assert inp.read() == 7.0


def test_a_message_that_arrived_before_the_worker_set_up_its_run_is_read():
    _, inp = _ports()
    quicker = {"/ros/in": codec_for(float).encode(3.5)}  # the bridge was quicker
    with _both_ends([], [inp], arrived=quicker) as (worker, _):
        worker.feeders[0]()
        assert inp.read() == 3.5
        assert worker.inputs() == {"/ros/in": {"read": 1, "superseded": 0}}


def test_a_fed_input_counts_the_messages_a_newer_one_replaced_and_reads_each_once():
    _, inp = _ports()
    with _both_ends([], [inp]) as (worker, channels):
        box = channels["/ros/in"]
        (feeder,) = worker.feeders
        seen = []
        for burst in ([1.0], [2.0, 3.0, 4.0], [], [5.0, 6.0], [7.0]):
            for v in burst:
                box.write(codec_for(float).encode(v))
            feeder()
            if inp.has_new_data:
                seen.append(inp.read())
        assert seen == [1.0, 4.0, 6.0, 7.0]  # each once: a new value is new once
        assert inp._slot.seq == 4
        # 7 arrived = 4 read + 3 replaced before an iteration read them
        assert worker.inputs() == {"/ros/in": {"read": 4, "superseded": 3}}
        assert box.version == 7


@pytest.mark.parametrize(
    "cls, values",
    [
        (float, [1.25, -0.0, 1e300]),
        (int, [0, -(2**63), 2**63 - 1]),
        (bool, [True, False]),
        (str, ["héllo", "", "x" * 100]),
    ],
)
def test_a_fed_input_decodes_every_kind_from_its_buffer(cls, values):
    inp = InputPort("/b", "in", cls)
    inp.topic = "/ros/in"
    with _both_ends([], [inp]) as (worker, channels):
        codec = codec_for(cls)
        (feeder,) = worker.feeders
        for value in values:
            channels["/ros/in"].write(codec.encode(value))
            feeder()
            got = inp.read()
            assert type(got) is cls and got == value


def test_a_fed_float_array_is_a_copy():
    np = pytest.importorskip("numpy")
    inp = InputPort("/b", "in", np.ndarray)
    inp.topic = "/ros/in"
    with _both_ends([], [inp]) as (worker, channels):
        (feeder,) = worker.feeders
        channels["/ros/in"].write(codec_for(np.ndarray).encode(np.array([1.0, 2.0])))
        feeder()
        first = inp.read()
        channels["/ros/in"].write(codec_for(np.ndarray).encode(np.array([3.0])))
        feeder()
        assert first.tolist() == [1.0, 2.0]  # not overwritten by the next message
        assert inp.read().tolist() == [3.0]


def test_a_mapped_input_carries_the_shortest_deadline_of_its_readers():
    out, inp = _ports()
    other = InputPort("/c", "in", float)
    other.topic = "/ros/in"
    inp._deadline_ns, other._deadline_ns = 500_000_000, 200_000_000
    ports = {p.topic: p for p in mapped_ports([out], [inp, other])}
    assert ports["/ros/in"].deadline == 0.2 and ports["/ros/out"].deadline == 0.0
    other._deadline_ns = 0  # no deadline: the other reader's counts
    assert {p.topic: p.deadline for p in mapped_ports([out], [inp, other])} == {
        "/ros/out": 0.0, "/ros/in": 0.5
    }
