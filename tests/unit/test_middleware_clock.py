"""MiddlewareClock (use_sim_time): /clock values from a mailbox, waited for on a doorbell."""

from __future__ import annotations

import threading
import time
from array import array

import pytest

from rtcf._core._clock import MiddlewareClock
from rtcf._core._rings import Mailbox
from rtcf._runtime._doorbell import Doorbell, RungMailbox


@pytest.fixture
def feed():
    """A /clock feed as the supervisor makes it: a mailbox rung on every write."""
    box = Mailbox.create(bytearray(Mailbox.nbytes(8)), 8)
    bell = Doorbell.create()
    yield box, bell, RungMailbox(box, bell)
    bell.close()
    box.close()


def publish_later(sink: RungMailbox, values_ns: list[int], gap_s: float) -> threading.Thread:
    def run() -> None:
        for ns in values_ns:
            time.sleep(gap_s)
            sink.write(ns.to_bytes(8, "little", signed=True))

    t = threading.Thread(target=run)
    t.start()
    return t


def test_now_waits_for_the_first_message(feed) -> None:
    box, bell, sink = feed
    clock = MiddlewareClock(box, array("q", [0]), doorbell=bell)
    t = publish_later(sink, [5_000_000_000], 0.05)
    assert clock.now_ns() == 5_000_000_000
    t.join()


def test_sleep_ends_when_clock_time_reaches_the_deadline(feed) -> None:
    box, bell, sink = feed
    clock = MiddlewareClock(box, array("q", [0]), doorbell=bell)
    sink.write((1_000).to_bytes(8, "little", signed=True))
    t = publish_later(sink, [1_500, 1_900, 2_000, 2_500], 0.05)
    clock.sleep_until_ns(2_000)
    # woken by the message that reached it, not by the earlier ones nor the next
    assert clock.now_ns() in (2_000, 2_500)
    t.join()
    assert clock.now_ns() == 2_500


def test_a_stop_with_a_ring_ends_the_wait_at_once(feed) -> None:
    box, bell, sink = feed
    stop = array("q", [0])
    clock = MiddlewareClock(box, stop, doorbell=bell)
    sink.write((0).to_bytes(8, "little", signed=True))

    def stop_soon() -> None:
        time.sleep(0.1)
        stop[0] = 1
        bell.ring()

    t = threading.Thread(target=stop_soon)
    t.start()
    t0 = time.monotonic()
    clock.sleep_until_ns(10**18)  # /clock never gets there
    assert time.monotonic() - t0 < 0.5
    t.join()


def test_a_stop_without_a_ring_ends_the_wait_within_the_bound(feed) -> None:
    """A signal handler sets the stop word and cannot rely on a ring."""
    box, bell, sink = feed
    stop = array("q", [0])
    clock = MiddlewareClock(box, stop, doorbell=bell)
    sink.write((0).to_bytes(8, "little", signed=True))
    timer = threading.Timer(0.05, lambda: stop.__setitem__(0, 1))
    timer.start()
    t0 = time.monotonic()
    clock.sleep_until_ns(10**18)
    assert time.monotonic() - t0 < 1.0
    timer.join()


def test_without_a_doorbell_it_polls(feed) -> None:
    box, _, sink = feed
    clock = MiddlewareClock(box, array("q", [0]), poll_ns=1_000_000)
    sink.write((0).to_bytes(8, "little", signed=True))
    t = publish_later(sink, [3_000], 0.05)
    clock.sleep_until_ns(3_000)
    assert clock.now_ns() == 3_000
    t.join()
