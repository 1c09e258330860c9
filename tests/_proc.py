"""The rtcf processes a test starts: their environment, reading their stderr while they
run, and stopping them (shared by the process tests of every folder; no middleware)."""

import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

_SEEN: dict[int, str] = {}


def _wait_until(proc, found, what, timeout):
    # reads the file descriptor itself: a buffered readline() would pull several
    # lines into Python's buffer, where select() no longer sees them
    fd = proc.stderr.fileno()
    deadline = time.monotonic() + timeout
    while True:
        seen = _SEEN.get(proc.pid, "")
        result = found(seen)
        if result:
            return result
        if time.monotonic() > deadline:
            raise AssertionError(f"no {what} in:\n{seen}")
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            chunk = os.read(fd, 65536)
            if not chunk:
                raise AssertionError(f"no {what} before the end of stderr:\n{seen}")
            _SEEN[proc.pid] = seen + chunk.decode(errors="replace")


def wait_for(proc, text, timeout=30.0):
    """Read ``proc``'s stderr until ``text`` shows; return everything read so far."""
    return _wait_until(proc, lambda s: s if text in s else "", repr(text), timeout)


def wait_for_match(proc, pattern, timeout=30.0):
    """Read ``proc``'s stderr until ``pattern`` matches; return the match."""
    return _wait_until(proc, lambda s: re.search(pattern, s), f"match of {pattern!r}", timeout)


def read_rest(proc, timeout=60.0):
    """Wait for ``proc`` to end; return (stdout, all of stderr including what was read)."""
    out, err = proc.communicate(timeout=timeout)
    return out, _SEEN.pop(proc.pid, "") + (err or "")


def env_with(*fixtures):
    """This environment with rtcf's src and the ``fixtures`` folders (of test components)
    first on PYTHONPATH, for an rtcf process a test starts."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), *map(str, fixtures), env.get("PYTHONPATH", "")])
    return env


def start_rtcf(env, *args, **kwargs):
    """``python -m rtcf ARGS`` in ``env``: stdout and stderr piped (text), no stdin."""
    return subprocess.Popen(
        [sys.executable, "-m", "rtcf", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=env,
        **kwargs,
    )


def wait_running(proc, timeout=30.0, text="running until Ctrl-C"):
    """Read ``proc``'s stderr until it says it runs (``text``); kill it if it does not."""
    try:
        return wait_for(proc, text, timeout)
    except AssertionError:
        proc.kill()
        raise


def stop(proc):
    """SIGINT, as Ctrl-C would: it ends, exit 0; (stdout, all of stderr)."""
    proc.send_signal(signal.SIGINT)
    out, err = read_rest(proc)
    assert proc.returncode == 0, err
    return out, err


def interrupt(proc, timeout=60.0):
    """SIGINT (Ctrl-C) if ``proc`` still runs, then wait for its end: (stdout, all of
    stderr). For a ``finally`` that must not raise: its exit status is the test's to
    check."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    return read_rest(proc, timeout=timeout)


def end_after_each_test(started, end, *, launchers_first=False):
    """An autouse fixture for a test module (assign it to a name there): after each test,
    ``end`` the processes in the list ``started`` and forget them. ``launchers_first``:
    one at a time, the last started first, so that launchers end while their runner
    still answers their unload requests."""

    @pytest.fixture(autouse=True)
    def end_started():
        yield
        if launchers_first:
            for proc in reversed(started):
                end(proc)
        else:
            end(*started)
        started.clear()

    return end_started


def rtcf_shm_names():
    """Names in /dev/shm that rtcf made (there must never be any: its memory is anonymous)."""
    try:
        return sorted(n for n in os.listdir("/dev/shm") if n.startswith("rtcf"))
    except FileNotFoundError:
        return []


def wait_for_count(proc, text, count, timeout=30.0):
    """Read ``proc``'s stderr until ``text`` has shown ``count`` times; return it all."""
    return _wait_until(
        proc, lambda s: s if s.count(text) >= count else "", f"{count} x {text!r}", timeout
    )


NETWORK_NAMESPACE = "root, unshare and ip (a network namespace)"


def can_make_network_namespace():
    """Whether this process can make a network namespace (run_in_network_namespace)."""
    return os.geteuid() == 0 and shutil.which("unshare") is not None \
        and shutil.which("ip") is not None


def run_in_network_namespace(script, env, timeout=60.0):
    """``sh -c SCRIPT`` in a network namespace of its own (``unshare --net``), lo up first
    with a route for multicast on it: python-can's udp_multicast bus (the simulated CAN
    drives) and DDS stay inside it, never on the machine's own interfaces. The script
    starts under ``set -e``; returns its stdout and stderr together."""
    preamble = "set -e\nip link set lo up\nip route add 224.0.0.0/4 dev lo\n"
    proc = subprocess.run(["unshare", "--net", "sh", "-c", preamble + script],
                          capture_output=True, text=True, timeout=timeout, env=env,
                          stdin=subprocess.DEVNULL)
    return proc.stdout + proc.stderr
