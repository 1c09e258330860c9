"""Shared memory between the real-time worker and the supervisor: anonymous segments.

A :class:`Segment` is anonymous memory (``memfd_create``), sealed to its size, that
the supervisor creates and hands to the worker as a file descriptor over their
control socket (``SCM_RIGHTS``). It has no name: nothing in ``/dev/shm`` or anywhere
else can outlive the processes that map it, whatever way they end (a supervisor
killed between creating a segment and the worker mapping it leaves nothing behind),
and no other process can open it. The channels that live in it
(:class:`~rtcf._core._rings.Ring`, :class:`~rtcf._core._rings.Mailbox`) are
buffer-agnostic and come from the core.
"""

from __future__ import annotations

import errno
import fcntl
import mmap
import os
import socket
import stat
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

from .._core._closing import Closing

__all__ = ["Passed", "Segment", "outgoing", "receive_segments", "send_segments"]

# no resizing once created: a peer cannot shrink it under the other's mapping (SIGBUS)
_SEALS = fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW | fcntl.F_SEAL_SEAL


class Segment(Closing):
    """Anonymous shared memory of a fixed size, shared by passing :attr:`fd`.

    ``name`` is a label for messages and ``/proc/<pid>/fd`` (``/memfd:<name>``), not a
    way to open it. The creator keeps :attr:`fd` until it has sent it to the peer
    (:meth:`close_fd`); the peer maps a received descriptor with :meth:`from_fd`.
    """

    __slots__ = ("_mmap", "buf", "fd", "name", "size")

    def __init__(self, name: str, mapping: mmap.mmap, fd: int = -1) -> None:
        self.name = name
        self.size = len(mapping)
        self.fd = fd
        self._mmap: mmap.mmap | None = mapping
        self.buf = memoryview(mapping)

    @classmethod
    def create(cls, size: int, name: str = "rtcf") -> Segment:
        """A new zero-filled segment of ``size`` bytes rounded up to whole pages."""
        if size <= 0:
            raise ValueError(f"segment size must be positive, not {size}")
        if not hasattr(os, "memfd_create"):
            raise RuntimeError(
                "rtcf's shared memory needs Linux (memfd_create, kernel 3.17 or newer)"
            )
        size = -(-size // mmap.PAGESIZE) * mmap.PAGESIZE
        fd = os.memfd_create(name, os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
        try:
            os.ftruncate(fd, size)
            try:
                # Reserve the pages now: a full tmpfs then fails here with ENOSPC,
                # not later with SIGBUS in the real-time loop.
                os.posix_fallocate(fd, 0, size)
            except OSError as exc:
                if exc.errno not in (errno.EOPNOTSUPP, errno.EINVAL, errno.ENOSYS):
                    raise
            fcntl.fcntl(fd, fcntl.F_ADD_SEALS, _SEALS)
            mapping = mmap.mmap(fd, size)
        except BaseException:
            os.close(fd)
            raise
        return cls(name, mapping, fd)

    @classmethod
    def from_fd(cls, fd: int, name: str = "rtcf") -> Segment:
        """Map the segment behind a received descriptor, and close the descriptor.

        Only a sealed memfd is accepted: a regular file or a segment its sender could
        still resize is refused, so the mapping can never shrink under the loop.
        """
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise ValueError(f"descriptor {fd} is not a shared-memory segment")
            try:
                seals = fcntl.fcntl(fd, fcntl.F_GET_SEALS)
            except OSError:
                seals = 0
            if seals & _SEALS != _SEALS:
                raise ValueError(
                    f"descriptor {fd} is not a sealed rtcf segment (a memfd sealed "
                    "against resizing is expected)"
                )
            if st.st_size == 0:
                raise ValueError(f"segment {name!r} is empty")
            mapping = mmap.mmap(fd, st.st_size)
        finally:
            os.close(fd)
        return cls(name, mapping)

    def handle(self) -> Segment:
        """One more handle on this segment, to hand to one more peer: a duplicate of
        the descriptor and no mapping (closing it closes only the duplicate)."""
        if self.fd < 0:
            raise RuntimeError(f"segment {self.name}: its descriptor was already handed over")
        other = Segment.__new__(Segment)
        other.name, other.size, other.fd = self.name, self.size, os.dup(self.fd)
        other._mmap = None
        other.buf = memoryview(b"")
        return other

    @property
    def closed(self) -> bool:
        return self._mmap is None

    def close_fd(self) -> None:
        """Drop the creator's descriptor (once the peer has its own). Idempotent."""
        fd, self.fd = self.fd, -1
        if fd >= 0:
            os.close(fd)

    def close(self) -> None:
        """Unmap. Idempotent. Every view derived from ``buf`` must be released first."""
        self.close_fd()
        mapping = self._mmap
        if mapping is None:
            return
        try:
            self.buf.release()
        except BufferError:
            raise BufferError(
                f"cannot close segment {self.name}: objects made from its buf (numpy "
                "arrays, ctypes objects) are still alive; views must be released first"
            ) from None
        try:
            mapping.close()
        except BufferError:
            self.buf = memoryview(mapping)  # still open and usable: close() can be retried
            raise BufferError(
                f"cannot close segment {self.name}: memoryviews of it (slices, casts, "
                "Ring.data, open Ring or Mailbox objects) are still alive; views must be "
                "released first (view.release(), ring.close(), mailbox.close())"
            ) from None
        self._mmap = None

    def __repr__(self) -> str:
        state = "closed" if self._mmap is None else f"{self.size} bytes"
        return f"<Segment {self.name} {state}>"


# -- handing segments over the control channel ----------------------------------


@dataclass(frozen=True)
class Passed:
    """Stands in a control message for a segment whose descriptor follows it."""

    name: str


def outgoing(args: tuple[Any, ...]) -> tuple[tuple[Any, ...], list[Segment]]:
    """``args`` with each Segment replaced by a :class:`Passed`, and those segments."""
    segments = [a for a in args if isinstance(a, Segment)]
    return tuple(Passed(a.name) if isinstance(a, Segment) else a for a in args), segments


def send_segments(conn: Connection, segments: list[Segment]) -> None:
    """Send the segments' descriptors (SCM_RIGHTS), right after the message naming them."""
    if segments:
        with _socket(conn) as sock:
            socket.send_fds(sock, [b"S"], [s.fd for s in segments])


def receive_segments(conn: Connection, args: tuple[Any, ...]) -> tuple[Any, ...]:
    """``args`` with each :class:`Passed` replaced by the segment received for it."""
    wanted = sum(isinstance(a, Passed) for a in args)
    if not wanted:
        return args
    with _socket(conn) as sock:
        _, fds, _, _ = socket.recv_fds(sock, 1, wanted, socket.MSG_CMSG_CLOEXEC)
    if len(fds) != wanted:
        for fd in fds:
            os.close(fd)
        raise RuntimeError(f"expected {wanted} shared-memory descriptors, received {len(fds)}")
    received = iter(fds)
    return tuple(
        Segment.from_fd(next(received), a.name) if isinstance(a, Passed) else a for a in args
    )


def _socket(conn: Connection) -> socket.socket:
    # a second socket object on a duplicate of the connection's descriptor; blocking
    # whatever socket.setdefaulttimeout() says (the flag is shared with the connection)
    sock = socket.fromfd(conn.fileno(), socket.AF_UNIX, socket.SOCK_STREAM)
    sock.setblocking(True)
    return sock
