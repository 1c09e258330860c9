"""An rclpy ActionClient for tests that act as a client from outside (what MoveIt does
with an action), with an executor of its own to spin it."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import rclpy
from rclpy.action import ActionClient


@contextmanager
def action_client(node: Any, action_type: Any, name: str) -> Iterator[Any]:
    """A client of the action ``name`` on ``node``, its server found, with two helpers:
    ``wait(future, timeout=20.0)`` its result (failing when none came in time) and
    ``until(predicate, timeout=10.0)`` whether ``predicate()`` became true, spinning."""
    client = ActionClient(node, action_type, name)
    assert client.wait_for_server(timeout_sec=30)
    executor = rclpy.executors.SingleThreadedExecutor(context=node.context)
    executor.add_node(node)

    def wait(future: Any, timeout: float = 20.0) -> Any:
        executor.spin_until_future_complete(future, timeout_sec=timeout)
        assert future.done(), "no answer in time"
        return future.result()

    def until(predicate: Any, timeout: float = 10.0) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.02)
        return bool(predicate())

    client.wait, client.until = wait, until
    try:
        yield client
    finally:
        executor.remove_node(node)
        client.destroy()
