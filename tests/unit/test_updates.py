"""The supervisor's side of the update ring: a batch of lifecycle transitions (a
controller manager's switch) reaches the worker whole or not at all, in order, and
each caller gets its own outcome."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from rtcf._core import _lifecycle as lc
from rtcf._core._errors import RtcfError
from rtcf._core._rings import Ring
from rtcf._core._tunables import LIFECYCLE, UPDATE_RING_RECORDS, decode_update, encode_update
from rtcf._runtime._loaded import LoadedComponents
from rtcf._runtime._shm import Segment
from rtcf._runtime._updates import WorkerUpdates, change_states


@pytest.fixture
def pair() -> Iterator[tuple[WorkerUpdates, Ring, Ring]]:
    """The supervisor's WorkerUpdates, and the worker's ends: updates in, outcomes out."""
    loaded = LoadedComponents(threading.Lock())
    for name in ("/a", "/b"):
        loaded.components[name] = {"name": name, "lifecycle": "active"}
    updates = WorkerUpdates(loaded)
    segment = updates.open(lambda size, name: Segment.create(size))
    incoming = Ring.open(segment.buf)
    outgoing = Ring.open(segment.buf[Ring.nbytes(UPDATE_RING_RECORDS, incoming.record_size):])
    yield updates, incoming, outgoing
    incoming.close()
    outgoing.close()
    updates.close()
    segment.close()


def test_a_batch_waits_whole_in_the_backlog_until_the_ring_has_room_for_all(pair) -> None:
    updates, incoming, _ = pair
    filler = encode_update(LIFECYCLE, "/x", "activate", 0)
    for _ in range(UPDATE_RING_RECORDS - 1):  # one slot left
        assert updates._ring is not None and updates._ring.push(filler)
    asked = updates.send_transitions([("/a", "deactivate"), ("/b", "activate")])
    assert len(incoming) == UPDATE_RING_RECORDS - 1  # no half of it went
    incoming.pop()  # the worker reads one: room for both
    updates.pump()
    records = [decode_update(incoming.pop()) for _ in range(len(incoming))][-2:]
    numbers = [number for number, _ in asked]
    assert records == [(LIFECYCLE, "/a", "deactivate", numbers[0]),
                       (LIFECYCLE, "/b", "activate", numbers[1])]


def test_each_transition_of_a_batch_gets_its_own_outcome_in_the_order_asked(pair) -> None:
    updates, incoming, outgoing = pair
    worker_side = threading.Event()

    def worker() -> None:  # answers in the order read, as the worker's loop does
        while len(incoming) < 2:
            worker_side.wait(0.001)
        first, second = (decode_update(incoming.pop()) for _ in range(2))
        outgoing.push(lc.encode_outcome(
            first[3], lc.TransitionOutcome(lc.DEACTIVATE, lc.ACTIVE, lc.INACTIVE, lc.SUCCESS)))
        outgoing.push(lc.encode_outcome(
            second[3], lc.TransitionOutcome(lc.ACTIVATE, lc.INACTIVE, lc.INACTIVE, lc.FAILURE,
                                            reason="start() returned False")))
        while updates.pending:  # the supervisor's main thread drains the outcomes
            updates.pump()
            worker_side.wait(0.001)

    t = threading.Thread(target=worker)
    t.start()
    a, b = change_states(
        [(updates, lambda: None, "/a", "deactivate"), (updates, lambda: None, "/b", "activate")],
        timeout=10.0)
    t.join()
    assert (a.ok, a.end_label) == (True, "inactive")
    assert (b.ok, b.reason) == (False, "start() returned False")
    assert updates.loaded.components["/a"]["lifecycle"] == "inactive"


def test_no_answer_in_time_is_a_refusal_naming_the_component(pair) -> None:
    updates, _, _ = pair
    [outcome] = change_states([(updates, lambda: None, "/a", "deactivate")], timeout=0.01)
    assert outcome.result == "refused"
    assert "'/a': no answer to 'deactivate' within 0.01 s" in outcome.reason
    assert updates.pending == {}


def test_more_transitions_than_a_worker_reads_in_one_iteration_are_refused(pair) -> None:
    updates, incoming, _ = pair
    with pytest.raises(RtcfError, match=f"{UPDATE_RING_RECORDS + 1} lifecycle transitions"):
        updates.send_transitions([("/a", "activate")] * (UPDATE_RING_RECORDS + 1))
    assert len(incoming) == 0 and updates.pending == {}
