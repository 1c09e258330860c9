"""Two "hosts" on this machine: network namespaces joined by a veth pair, as two
computers on one Ethernet link (ros2_latency.py --hosts 2, tests/ros2/test_several_hosts.py).

Each namespace holds its loopback and its end of the link (10.231.N.1 and .2), with a
multicast route for DDS discovery, and nothing else: no other interface, no default
route, so no traffic leaves them. Run a command on a host with :func:`on_host`. Fast
DDS must be kept off its shared-memory transport (:data:`UDP_ONLY`): between two real
hosts there is none, and on one machine it would carry the data past the link.
Creating namespaces needs root (CAP_NET_ADMIN).
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass

UDP_ONLY = {"FASTDDS_BUILTIN_TRANSPORTS": "UDPv4"}  # Fast DDS 2.13+ (ROS 2 Jazzy's 2.14)
NEEDS = "network namespaces and a veth pair need root (CAP_NET_ADMIN)"


@dataclass(frozen=True)
class Host:
    namespace: str
    link: str  # its end of the veth pair
    address: str

    def command(self, *cmd: str) -> list[str]:
        """``cmd`` run in this host's namespace."""
        return ["ip", "netns", "exec", self.namespace, *cmd]

    def received_bytes(self) -> int:
        """Bytes its end of the link has received."""
        out = _ip("-n", self.namespace, "-j", "-s", "link", "show", self.link)
        return int(json.loads(out)[0]["stats64"]["rx"]["bytes"])


def _ip(*args: str) -> str:
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip()}")
    return done.stdout


@contextlib.contextmanager
def two_hosts(tag: str = "") -> Iterator[tuple[Host, Host]]:
    """Two namespaces joined by a veth pair; removed on exit (their links with them)."""
    if os.geteuid() != 0:
        raise PermissionError(NEEDS)
    tag = tag or str(os.getpid() % 100000)
    subnet = f"10.231.{int(tag) % 250 if tag.isdigit() else 0}"
    hosts = tuple(
        Host(f"rtcf_{side}{tag}", f"rtcf{side}{tag}", f"{subnet}.{k + 1}")
        for k, side in enumerate("ab")
    )
    made: list[str] = []
    try:
        for h in hosts:
            _ip("netns", "add", h.namespace)
            made.append(h.namespace)
        _ip("link", "add", hosts[0].link, "type", "veth", "peer", "name", hosts[1].link)
        for h in hosts:
            _ip("link", "set", h.link, "netns", h.namespace)
            _ip("-n", h.namespace, "addr", "add", f"{h.address}/24", "dev", h.link)
            _ip("-n", h.namespace, "link", "set", "lo", "up")
            _ip("-n", h.namespace, "link", "set", h.link, "up")
            _ip("-n", h.namespace, "route", "add", "224.0.0.0/4", "dev", h.link)
        yield hosts[0], hosts[1]
    finally:
        for ns in made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)
