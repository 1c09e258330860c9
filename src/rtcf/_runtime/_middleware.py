"""What the ROS 1 and ROS 2 bridges share that names no middleware: their client
library imported with an error that says how to install it, the message class a
mapped port crosses as, and what a bridge is told of a parameter a component set.

The bridges never import each other (the layers in pyproject.toml); this sits below
them. It imports no middleware itself: the bridge names its library, which is imported
only when that bridge runs.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .._core._errors import RtcfError
from .._core._log import LogRecord
from .._core._message_types import STD_MESSAGES, message_class, std_type_name

if TYPE_CHECKING:
    from ._port_channels import MappedPort


def import_client(module: str, middleware: str, how: str) -> Any:
    """The client library ``module`` (rclpy, rospy) of ``--middleware middleware``; where
    it is missing, an RtcfError saying ``how`` to get it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise RtcfError(f"--middleware {middleware} needs {module} ({exc}); {how}") from None


def mapped_message_class(port: MappedPort, *, ros2: bool, install: str) -> type:
    """The message class a mapped port is published or subscribed as: std_msgs' for a
    primitive kind, else its own type; where it is missing, an RtcfError naming the
    topic and how to ``install`` its package."""
    name = std_type_name(port.kind, ros2=ros2) if port.kind in STD_MESSAGES else port.type_name
    try:
        return message_class(name)
    except LookupError as exc:
        raise RtcfError(f"topic {port.topic}: {exc}; install its package ({install})") from None


def parameter_set(bridge: Any, log_sink: Callable[[LogRecord], None], name: str, value: Any
                  ) -> None:
    """A component set a parameter (``params.set()``): tell the middleware's parameters
    (a bridge's ``parameter_set``, if it has one); where it fails, the loop goes on and
    the log says why the middleware missed it."""
    tell = getattr(bridge, "parameter_set", None)
    if tell is not None:
        try:
            tell(name, value)
        except Exception as exc:
            log_sink(LogRecord(30, "rt_runner", f"parameter {name} was set to {value!r} "
                                                f"in the runner but not in the middleware: {exc}"))
