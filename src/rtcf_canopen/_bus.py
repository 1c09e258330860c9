"""The CAN bus of a Cia402System: opened with python-can, and canopen's SDO client
served without canopen's Notifier thread.

canopen's ``Network.connect`` starts a ``can.Notifier``: a thread that receives every
frame and calls the subscribers. The loop's worker runs one thread (a second one
multiplies its tail jitter by ten: docs/realtime.md), so here no thread receives: the
hardware's ``read`` drains the bus itself, and while the drives are brought up over SDO
(in ``on_configure``, outside the loop) the SDO client's wait for a response *is* the
receiving: :class:`PolledSdoClient` takes frames from the bus and hands them to
canopen's subscribers until its answer is there, then lets canopen go on as usual.
"""

from __future__ import annotations

import logging
import queue
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import can
import canopen
from canopen.sdo import SdoClient, SdoCommunicationError

INTERFACES = ("udp_multicast", "socketcan", "virtual")


class BusSettings:
    """The ``<hardware>`` tag's bus parameters: ``interface``, ``channel``, ``bitrate``."""

    def __init__(self, interface: str, channel: str, bitrate: int) -> None:
        self.interface = interface
        self.channel = channel
        self.bitrate = bitrate

    def __str__(self) -> str:
        return f"{self.interface}:{self.channel}"

    @property
    def filters_in_kernel(self) -> bool:
        """Whether python-can filters frames before they reach Python (socketcan's
        CAN_RAW_FILTER); elsewhere it filters in ``recv``, after building each message."""
        return self.interface == "socketcan"

    def open(self) -> can.BusABC:
        """The python-can bus (no Notifier, no filters: a filtered frame would end a
        non-blocking drain early in python-can's ``recv``)."""
        kwargs: dict[str, Any] = {"interface": self.interface, "channel": self.channel}
        if self.interface == "socketcan":
            pass  # the bitrate is the kernel's (ip link set can0 type can bitrate ...)
        elif self.interface == "udp_multicast":
            kwargs["fd"] = False
        elif self.bitrate and self.interface != "virtual":
            kwargs["bitrate"] = self.bitrate
        if self.interface == "virtual":
            kwargs["receive_own_messages"] = False
        return can.Bus(**kwargs)


def pump(network: canopen.Network, until: float) -> None:
    """Hand the bus's frames to canopen's subscribers until ``until`` (monotonic), or
    until the bus is quiet (not real-time: for the bring-up only)."""
    bus = network.bus
    assert bus is not None
    while True:
        left = until - time.monotonic()
        msg = bus.recv(timeout=max(0.0, left))
        if msg is None:
            return
        network.notify(msg.arbitration_id, msg.data, msg.timestamp)
        if left <= 0:
            return


class PolledSdoClient(SdoClient):
    """canopen's SDO client, whose wait for a response receives from the bus itself."""

    network: canopen.Network

    def read_response(self) -> bytes:
        deadline = time.monotonic() + self.RESPONSE_TIMEOUT
        bus = self.network.bus
        assert bus is not None
        while self.responses.empty():
            left = deadline - time.monotonic()
            if left <= 0:
                raise SdoCommunicationError("No SDO response received")
            msg = bus.recv(timeout=left)
            if msg is not None:
                self.network.notify(msg.arbitration_id, msg.data, msg.timestamp)
        return bytes(super().read_response())

    def request_response(self, sdo_request: bytes) -> bytes:
        if not self.responses.empty():
            self.responses = queue.Queue()
        return bytes(super().request_response(sdo_request))


class PolledRemoteNode(canopen.RemoteNode):
    """A canopen RemoteNode whose SDO client receives by polling the bus."""

    def add_sdo(self, rx_cobid: int, tx_cobid: int) -> SdoClient:
        client = PolledSdoClient(rx_cobid, tx_cobid, self.object_dictionary)
        client.MAX_RETRIES = 1  # one attempt: an absent drive is said once, at once
        self.sdo_channels.append(client)
        if self.has_network():
            self.network.subscribe(client.tx_cobid, client.on_response)
        return client


@contextmanager
def quiet_canopen() -> Iterator[None]:
    """canopen's own log lines off while the plugin says what happened in its words
    (a timed-out SDO would otherwise add 'Transfer aborted by client...')."""
    log = logging.getLogger("canopen")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)
