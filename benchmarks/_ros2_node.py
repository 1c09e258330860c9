"""What the ROS 2 benchmarks' rclpy child processes share (the ROS-only nodes, the
latency probe, the soak's counting subscriber): rclpy started with handlers of our own
for SIGINT and SIGTERM, and the spin until one comes."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable
from typing import Any


def start_node(name: str) -> Any:
    """rclpy initialised, and a node ``name``. A signal raises KeyboardInterrupt: our own
    handlers, as rclpy's would shut the context down under a running callback."""
    import rclpy
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    def stop(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    return Node(name)


def spin_until_stopped(node: Any, ready: Callable[[], None]) -> None:
    """Say ``ready``, then spin ``node`` until a signal (or the context's end); end it."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    executor = SingleThreadedExecutor()
    executor.add_node(node)
    ready()
    try:
        while True:  # a timeout, so that a signal is seen even while no message comes
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        with contextlib.suppress(Exception):
            rclpy.try_shutdown()
