"""A doorbell: how the worker wakes the supervisor when a mapped output was written.

An eventfd (Linux). The supervisor's middleware bridge makes it and its publishing
thread sleeps on it, so that a message reaches the middleware as soon as its
iteration has ended, and an idle bridge costs no CPU (polling the rings every half
millisecond cost about a third of a core). The worker inherits the descriptor and
rings it once after each iteration in which an output pushed a record, outside the
iteration's measured time: one non-blocking write(2) that never waits (the counter
saturates only after 2**64 - 2 rings). Rings that come before the supervisor wakes
make one wake-up: it drains every ring each time.

Under ``use_sim_time`` a second doorbell goes the other way: the supervisor rings it
with every /clock message (and when it asks the loop to stop), and the worker's
clock sleeps on it rather than polling the clock's mailbox.
"""

from __future__ import annotations

import os
import select
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .._core._rings import Mailbox

_ONE = (1).to_bytes(8, "little")


class Doorbell:
    """Both ends of an eventfd: ``ring`` in the worker, ``wait`` in the supervisor."""

    __slots__ = ("_poll", "_write", "fd")

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._write = os.write
        self._poll: select.poll | None = None

    @classmethod
    def create(cls) -> Doorbell:
        return cls(os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC))

    def ring(self) -> None:
        """Wake the supervisor (worker side; never blocks)."""
        try:
            self._write(self.fd, _ONE)
        except BlockingIOError:  # saturated: it is ringing already
            pass

    def wait(self, timeout_s: float) -> bool:
        """Sleep until rung or ``timeout_s`` passed; True when rung. Resets the bell."""
        if self._poll is None:
            self._poll = select.poll()
            self._poll.register(self.fd, select.POLLIN)
        if not self._poll.poll(timeout_s * 1000.0):
            return False
        try:
            os.read(self.fd, 8)
        except BlockingIOError:  # another reader took it
            return False
        return True

    def close(self) -> None:
        fd, self.fd = self.fd, -1  # first: a late ring must not find the number
        if fd >= 0:
            os.close(fd)


class RungMailbox:
    """A latest-value mailbox whose every write also rings a doorbell, for a reader
    that sleeps on the doorbell instead of polling the mailbox (the worker's /clock)."""

    __slots__ = ("bell", "box")

    def __init__(self, box: Mailbox, bell: Doorbell) -> None:
        self.box = box
        self.bell = bell

    def write(self, data: bytes) -> None:
        self.box.write(data)
        self.bell.ring()


class ClockFeed:
    """Every /clock message (use_sim_time) into the mailbox of every lane's worker; a
    lane started later gets the newest at once. What a bridge's ``follow_clock`` feeds."""

    def __init__(self) -> None:
        self.boxes: list[RungMailbox] = []
        self.last: bytes | None = None

    def add(self, box: RungMailbox) -> None:
        self.boxes.append(box)  # (atomic: the bridge's thread may be in write)
        if self.last is not None:
            box.write(self.last)

    def write(self, data: bytes) -> None:
        self.last = data
        for box in self.boxes:
            box.write(data)
