"""Two "hosts" for the ROS 2 tests that cross a network (test_several_hosts.py,
test_partition.py, controllers/test_diffbot_partition.py): benchmarks/_hosts.py's two
network namespaces joined by a veth pair, processes started on either, and the link
taken down and up again, as a cable pulled and put back.

Without root the tests fail (not skip) with one line saying why: CI runs them as root.
"""

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from .conftest import rtcf_env

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))
import _hosts  # noqa: E402  (benchmarks/_hosts.py: ros2_latency.py --hosts 2 uses it too)

sys.path.pop(0)

Host = _hosts.Host


def two_hosts(test: str) -> Iterator[tuple[Host, Host]]:
    """The body of a ``hosts`` fixture: two namespaces joined by a veth pair, removed
    afterwards; ``test`` names the module in the failure without root."""
    if os.geteuid() != 0:
        pytest.fail(f"{test}: {_hosts.NEEDS}: run the ROS 2 suite as root, as CI does")
    with _hosts.two_hosts() as pair:
        yield pair


def host_env(*extra: dict[str, str]) -> dict[str, str]:
    """The environment of a ROS 2 process on a host: DDS over UDP only (no shared
    memory past the link), discovery over the subnet, benchmarks/ importable."""
    env = {**rtcf_env(), **_hosts.UDP_ONLY}
    env["PYTHONPATH"] += os.pathsep + str(BENCHMARKS)
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    for e in extra:
        env.update(e)
    return env


def start_on(host: Host, *args: object, env: dict[str, str] | None = None) -> subprocess.Popen:
    """``python ARGS`` on ``host`` (stdout and stderr piped, text, no stdin)."""
    return subprocess.Popen(
        host.command(sys.executable, *map(str, args)), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True, env=env or host_env(),
    )


def set_link(host: Host, up: bool) -> None:
    """Take ``host``'s end of the link down (the cable pulled) or up again."""
    _hosts._ip("-n", host.namespace, "link", "set", host.link, "up" if up else "down")
