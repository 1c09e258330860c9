"""What a launch file describes, independent of its dialect (ROS 1 or ROS 2 XML).

The XML readers (``_launch_xml``) produce a :class:`LaunchDescription`; the
deployment step (``_deployment``) picks the rtcf runner and launcher nodes out of it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from .._core._errors import Location
from .._core._params import ParameterStore

Dialect = Literal["ros1", "ros2"]


@dataclass
class NodeDescription:
    """One ``<node>`` element after substitution and scoping.

    ``namespace`` is absolute ('/' or '/a/b'). ``remaps`` holds the rules in force
    for this node in order: those of enclosing ``<launch>``/``<group>`` scopes first,
    then the node's own; a later rule with the same ``from`` overrides an earlier one.
    The node's private parameters are in the description's parameter tree under
    ``namespace/name``.
    """

    package: str
    executable: str  # ROS 1 'type', ROS 2 'exec'
    name: str
    namespace: str
    location: Location
    dialect: Dialect
    args: str = ""
    remaps: list[tuple[str, str]] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)
    output: str | None = None
    # the <param from=...> files given to it, in order (a runner reads its controller
    # manager's section from them: _controller_setup)
    params_files: list[str] = field(default_factory=list)
    # "shutdown" when the node's exit ends the launch: ROS 2 on_exit="shutdown", ROS 1
    # required="true" (rtcf launch then stops the loop; only other nodes are affected)
    on_exit: str | None = None

    @property
    def full_name(self) -> str:
        return (
            self.namespace + self.name if self.namespace == "/" else f"{self.namespace}/{self.name}"
        )


@dataclass
class LaunchDescription:
    """Everything a launch file (with its includes) sets up."""

    source: str
    nodes: list[NodeDescription] = field(default_factory=list)
    parameters: ParameterStore = field(default_factory=ParameterStore)
    args: dict[str, str] = field(default_factory=dict)  # final values of top-level args
    warnings: list[str] = field(default_factory=list)
    # where each <param> set its parameter (full name -> the element's file and line)
    param_locations: dict[str, Location] = field(default_factory=dict)
