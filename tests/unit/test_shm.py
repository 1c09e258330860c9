"""Anonymous shared-memory segments: sealed memfds handed over as descriptors."""

from __future__ import annotations

import fcntl
import os
import socket
import tempfile
from multiprocessing.connection import Connection

import pytest

from rtcf._runtime._shm import Passed, Segment, outgoing, receive_segments, send_segments

from .._proc import rtcf_shm_names


def test_a_segment_has_no_name_anywhere() -> None:
    with Segment.create(100, "rtcf-unit") as seg:
        assert os.readlink(f"/proc/self/fd/{seg.fd}") == "/memfd:rtcf-unit (deleted)"
        assert seg.size == os.fstat(seg.fd).st_size == os.sysconf("SC_PAGE_SIZE")
        assert seg.buf.nbytes == seg.size and seg.buf.tobytes() == bytes(seg.size)
        assert rtcf_shm_names() == []
    assert seg.closed and seg.fd == -1


def test_a_segment_is_sealed_against_resizing() -> None:
    with Segment.create(8192) as seg:
        seals = fcntl.fcntl(seg.fd, fcntl.F_GET_SEALS)
        wanted = fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW | fcntl.F_SEAL_SEAL
        assert seals & wanted == wanted
        with pytest.raises(PermissionError):
            os.ftruncate(seg.fd, 4096)  # a peer cannot shrink it under the loop's mapping
        with pytest.raises(PermissionError):
            os.ftruncate(seg.fd, 3 * 8192)


def test_from_fd_maps_the_same_memory_and_closes_the_descriptor() -> None:
    with Segment.create(8192) as seg:
        fd = os.dup(seg.fd)
        with Segment.from_fd(fd, "peer") as other:
            with pytest.raises(OSError):
                os.fstat(fd)  # closed: the mapping holds the memory
            assert other.size == seg.size and other.name == "peer"
            seg.buf[10:15] = b"hello"
            assert other.buf[10:15] == b"hello"
            other.buf[0] = 42
            assert seg.buf[0] == 42


def test_from_fd_refuses_what_is_not_a_sealed_segment() -> None:
    with tempfile.TemporaryFile() as f:
        f.write(b"x" * 4096)
        f.flush()
        with pytest.raises(ValueError, match="not a sealed rtcf segment"):
            Segment.from_fd(os.dup(f.fileno()))
    unsealed = os.memfd_create("plain")
    os.ftruncate(unsealed, 4096)
    with pytest.raises(ValueError, match="not a sealed rtcf segment"):
        Segment.from_fd(unsealed)
    r, w = os.pipe()
    os.close(w)
    with pytest.raises(ValueError, match="not a shared-memory segment"):
        Segment.from_fd(r)


def test_segments_travel_over_a_connection_in_place_of_their_placeholders() -> None:
    a, b = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    ours, theirs = Connection(a.detach()), Connection(b.detach())
    try:
        with Segment.create(4096, "rtcf-one") as one, Segment.create(8192, "rtcf-two") as two:
            one.buf[0], two.buf[0] = 1, 2
            args, segments = outgoing(("run", one, 7, None, two))
            assert args == ("run", Passed("rtcf-one"), 7, None, Passed("rtcf-two"))
            assert segments == [one, two]
            ours.send(args)
            send_segments(ours, segments)
            got = receive_segments(theirs, theirs.recv())
            kinds = [type(x).__name__ for x in got]
            assert kinds == ["str", "Segment", "int", "NoneType", "Segment"]
            assert (got[1].name, got[1].size, got[1].buf[0]) == ("rtcf-one", 4096, 1)
            assert (got[4].name, got[4].size, got[4].buf[0]) == ("rtcf-two", 8192, 2)
            got[4].buf[1] = 99
            assert two.buf[1] == 99
            got[1].close()
            got[4].close()
            # a message without segments carries no descriptors and needs none
            ours.send(("stop",))
            assert receive_segments(theirs, theirs.recv()) == ("stop",)
    finally:
        ours.close()
        theirs.close()


def test_segment_size_must_be_positive() -> None:
    with pytest.raises(ValueError, match="must be positive"):
        Segment.create(0)
