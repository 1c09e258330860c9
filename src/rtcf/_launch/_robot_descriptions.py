"""The robot description a runner of a launch file uses, found as ros2_control finds it.

ros2_control Jazzy's controller manager subscribes to ``robot_description`` (relative:
``<its namespace>/robot_description``, after its remaps; std_msgs/String, transient
local), which ``robot_state_publisher`` publishes from its ``robot_description``
parameter; Humble and Iron took it from the manager's own ``robot_description``
parameter first (deprecated there, gone in Jazzy) and subscribed to
``~/robot_description``, which bringups remap to ``/robot_description``. ROS 1's
ros_control reads the parameter ``robot_description`` from the parameter server.

Under ``rtcf launch`` no robot_state_publisher runs and no topic is read: the launch
file is. A runner (``rt_runner`` or ``ros2_control_node``) takes, in this order:

1. its own ``robot_description`` parameter, or the file its ``robot_description_file``
   parameter names (an rtcf runner's own convenience);
2. the ``robot_description`` parameter of the ROS 2 ``robot_state_publisher`` node of
   the file whose topic (``robot_description`` in its namespace, after its remaps) is
   the one the runner subscribes to (``robot_description`` in the runner's namespace
   after its remaps, or where a remap of ``~/robot_description`` points);
3. a ``robot_description`` parameter in the runner's namespace or the nearest one above
   it (ROS 1: ``<param name="robot_description" command="xacro ..."/>``).

The text is kept with where it was given (the ``<param>``'s file and line) and parsed
at once (:func:`rtcf._core._robot_description.parse`), so that an error names that
place and the line inside the description. A description without a ``<ros2_control>``
tag (a robot_state_publisher's for a robot without ros2_control) has no hardware.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

from .._core._errors import LaunchError, Location
from .._core._names import Resolver, join, namespace_of
from .._core._robot_description import HardwareInfo, parse
from ._description import LaunchDescription, NodeDescription

PARAM = "robot_description"
FILE_PARAM = "robot_description_file"
PUBLISHER = ("robot_state_publisher", "robot_state_publisher")  # package, executable
CONTROL_NODE = ("controller_manager", "ros2_control_node")


@dataclass(frozen=True)
class RobotDescription:
    """A robot description (the URDF text, xacro already run) and where it came from."""

    text: str
    location: Location  # the <param> (or node) that gave it
    origin: str  # in words: "robot_state_publisher /rsp's parameter robot_description"
    hardware: tuple[HardwareInfo, ...] = ()  # one per <ros2_control> tag

    @property
    def source(self) -> str:
        """How errors about the text name it (the line inside it follows): the file and
        line of its ``<param>``, or a topic's or parameter's name."""
        return self.location.file if self.location.line is None else f"{self.location}: {PARAM}"

    def summary(self) -> str:
        """One line: where it came from and the hardware it names."""
        if not self.hardware:
            what = "no <ros2_control> tag (no hardware)"
        else:
            what = "hardware " + "; ".join(_hardware_line(h) for h in self.hardware)
        where = "" if self.location.line is None else f" ({self.location})"
        return f"robot description from {self.origin}{where}: {what}"


def _hardware_line(info: HardwareInfo) -> str:
    parts = [f"{len(info.joints)} joint{'s' * (len(info.joints) != 1)}"]
    parts += [f"{len(items)} {kind}{'s' * (len(items) != 1)}"
              for kind, items in (("sensor", info.sensors), ("gpio", info.gpios)) if items]
    return f"{info.name} ({info.type}, {info.hardware_plugin_name}: {', '.join(parts)})"


def read(text: str, location: Location, origin: str) -> RobotDescription:
    """The description ``text``, parsed; errors name ``location``."""
    described = RobotDescription(text, location, origin)
    if "<ros2_control" not in text:
        return described
    return RobotDescription(text, location, origin, tuple(parse(text, described.source)))


def for_runner(
    node: NodeDescription, description: LaunchDescription, warnings: list[str]
) -> RobotDescription | None:
    """The description runner ``node`` uses (see the module's docstring), or None."""
    params = description.parameters
    locations = description.param_locations
    own = f"{node.full_name}/{PARAM}"
    text = params.get(own, None)
    if isinstance(text, str) and text.strip():
        if (node.package, node.executable) == CONTROL_NODE:
            warnings.append(
                f"{locations.get(own, node.location)}: {node.full_name}'s {PARAM} parameter "
                "is read, as ros2_control Humble and Iron read it (deprecated there); "
                "Jazzy's controller manager ignores it and waits for the robot_description "
                "topic (robot_state_publisher's)"
            )
        return read(text, locations.get(own, node.location),
                    f"{node.executable} {node.full_name}'s parameter {PARAM}")
    own_file = f"{node.full_name}/{FILE_PARAM}"
    path = params.get(own_file, None)
    if isinstance(path, str) and path.strip():
        where = locations.get(own_file, node.location)
        try:
            with open(os.path.expanduser(path), encoding="utf-8") as f:
                text = f.read()
        except OSError as exc:
            raise LaunchError(
                f"{node.full_name}'s {FILE_PARAM} {path!r}: cannot read it ({exc.strerror}); "
                "give the path of the robot's URDF", file=where.file, line=where.line) from None
        return read(text, Location(path), f"{node.executable} {node.full_name}'s {FILE_PARAM}")
    found = _from_publisher(node, description.nodes, description, warnings)
    if found is not None:
        return found
    namespace = node.namespace
    while True:
        name = join(namespace, PARAM)
        text = params.get(name, None)
        if isinstance(text, str) and text.strip():
            return read(text, locations.get(name, node.location), f"parameter {name}")
        if namespace == "/":
            return None
        namespace = namespace_of(namespace)


def subscribed_topic(node: NodeDescription) -> str:
    """Where a runner (as ros2_control's controller manager) reads the description:
    ``robot_description`` after its remaps (Jazzy), or where a remap of
    ``~/robot_description`` (Humble's and Iron's topic) points."""
    resolver = Resolver(node.namespace, node.name, node.remaps)
    private = resolver.resolve("~/" + PARAM)
    if private != resolver.expand("~/" + PARAM):
        return private
    return resolver.resolve(PARAM)


def _published_topic(node: NodeDescription) -> str:
    return Resolver(node.namespace, node.name, node.remaps).resolve(PARAM)


def _from_publisher(
    runner: NodeDescription,
    nodes: Sequence[NodeDescription],
    description: LaunchDescription,
    warnings: list[str],
) -> RobotDescription | None:
    publishers = [n for n in nodes if (n.package, n.executable) == PUBLISHER
                  and n.dialect == "ros2"]
    if not publishers:
        return None
    topic = subscribed_topic(runner)
    matching = [n for n in publishers if _published_topic(n) == topic]
    if not matching:
        theirs = ", ".join(f"{n.full_name} on {_published_topic(n)}" for n in publishers)
        warnings.append(
            f"{runner.location}: {runner.executable} {runner.full_name} reads the robot "
            f"description from {topic}, where no robot_state_publisher of the file publishes "
            f"it ({theirs}); remap one of them"
        )
        return None
    publisher = matching[0]
    if len(matching) > 1:
        warnings.append(
            f"{runner.location}: several robot_state_publisher nodes publish {topic} "
            f"({', '.join(n.full_name for n in matching)}); {runner.full_name} takes "
            f"{publisher.full_name}'s"
        )
    name = f"{publisher.full_name}/{PARAM}"
    text = description.parameters.get(name, None)
    if not isinstance(text, str) or not text.strip():
        warnings.append(
            f"{publisher.location}: robot_state_publisher {publisher.full_name} has no "
            f"{PARAM} parameter, so {runner.full_name} has no robot description"
        )
        return None
    return read(text, description.param_locations.get(name, publisher.location),
                f"robot_state_publisher {publisher.full_name}'s parameter {PARAM} "
                f"(topic {topic})")
