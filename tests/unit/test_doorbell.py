import os
import subprocess
import sys
import time

from rtcf._runtime._doorbell import Doorbell


def test_wait_times_out_when_nobody_rings():
    bell = Doorbell.create()
    try:
        t0 = time.monotonic()
        assert bell.wait(0.05) is False
        assert time.monotonic() - t0 >= 0.04
    finally:
        bell.close()


def test_many_rings_make_one_wake_up():
    bell = Doorbell.create()
    try:
        for _ in range(5):
            bell.ring()
        assert bell.wait(1.0) is True
        assert bell.wait(0.01) is False  # reset by the first wait
    finally:
        bell.close()


def test_a_saturated_bell_does_not_block_or_raise():
    bell = Doorbell.create()
    try:
        os.eventfd_write(bell.fd, 2**64 - 2)  # the counter's maximum
        bell.ring()  # would block (EAGAIN): must return at once
        assert bell.wait(0.1) is True
    finally:
        bell.close()


def test_another_process_rings_the_inherited_descriptor():
    bell = Doorbell.create()
    try:
        code = (
            "import sys, time; from rtcf._runtime._doorbell import Doorbell; "
            "time.sleep(0.2); Doorbell(int(sys.argv[1])).ring()"
        )
        child = subprocess.Popen(
            [sys.executable, "-c", code, str(bell.fd)], pass_fds=(bell.fd,)
        )
        t0 = time.monotonic()
        assert bell.wait(10.0) is True
        assert time.monotonic() - t0 < 5.0
        assert child.wait(timeout=10) == 0
    finally:
        bell.close()


def test_close_is_idempotent():
    bell = Doorbell.create()
    bell.close()
    bell.close()
    assert bell.fd == -1
