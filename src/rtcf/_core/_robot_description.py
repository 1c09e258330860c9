"""The robot description: a URDF's ``<ros2_control>`` tags, read as ros2_control reads them.

:func:`parse` takes a URDF (already xacro-processed: the text a ``robot_description``
topic or parameter holds) and returns one :class:`HardwareInfo` per ``<ros2_control>``
tag, with ros2_control Jazzy's schema (``hardware_interface/hardware_info.hpp``) and
checks (``component_parser.cpp``): the hardware plugin and its parameters, joints,
sensors and GPIOs with their command and state interfaces, transmissions, mimic joints,
and per joint its limits (the URDF joint's ``<limit>`` narrowed by the interfaces'
``min``/``max``) and soft limits (``<safety_controller>``). :func:`joint_limits` gives
the limits of every movable joint of a description, for the hardware's command limits
(:mod:`._command_limits`).

Every error is a :class:`ConfigurationError` of one line: the source and line, the
``<ros2_control>`` tag by name, the tag at fault, and ros2_control's own words. The XML
is read with :mod:`xml.parsers.expat` (ElementTree drops line numbers), nothing else:
no middleware, no urdfdom; the URDF's own rules that ros2_control gets from urdfdom
(joint types, links forming one tree, ``<limit>`` on revolute and prismatic joints)
are checked here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Literal
from xml.parsers import expat

from ._command_limits import JointLimits
from ._errors import ConfigurationError

INF = math.inf
HardwareType = Literal["system", "actuator", "sensor"]
_HARDWARE_TYPES = ("system", "actuator", "sensor")
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
_POSITIVE_INT = re.compile(r"[1-9][0-9]*")
_INT_ARRAY = re.compile(r"\[\s*(-?[0-9]+\s*(,\s*-?[0-9]+\s*)*)?\]")
_INT_MAX = 2**31 - 1


# --------------------------------------------------------------------------- the schema


@dataclass(frozen=True)
class InterfaceInfo:
    """A ``<command_interface>`` or ``<state_interface>``. ``min``, ``max`` and
    ``initial_value`` are the texts of their ``<param>`` tags ("" when absent), as in
    ros2_control: what they mean depends on ``data_type``; the joints' numeric limits
    are in :attr:`HardwareInfo.limits`."""

    name: str
    min: str = ""
    max: str = ""
    initial_value: str = ""
    data_type: str = "double"
    size: int = 1
    enable_limits: bool = True
    parameters: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class ComponentInfo:
    """A ``<joint>``, ``<sensor>`` or ``<gpio>`` (``type``). ``is_mimic`` is the joint's
    ``mimic`` attribute: None when not set (the URDF's ``<mimic>`` decides)."""

    name: str
    type: Literal["joint", "sensor", "gpio"]
    command_interfaces: tuple[InterfaceInfo, ...] = ()
    state_interfaces: tuple[InterfaceInfo, ...] = ()
    parameters: Mapping[str, str] = field(default_factory=dict)
    is_mimic: bool | None = None
    enable_limits: bool = True


@dataclass(frozen=True)
class MimicJoint:
    """A joint of the hardware that follows another of its joints (the URDF's
    ``<mimic>``): ``position = multiplier * mimicked position + offset``. The indices
    are into :attr:`HardwareInfo.joints`."""

    joint: str
    mimicked_joint: str
    joint_index: int
    mimicked_joint_index: int
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class JointInfo:
    """A ``<joint>`` of a ``<transmission>``; its interface names are those of the
    hardware's joint of that name."""

    name: str
    role: str
    state_interfaces: tuple[str, ...] = ()
    command_interfaces: tuple[str, ...] = ()
    mechanical_reduction: float = 1.0
    offset: float = 0.0
    read_only: bool = False


@dataclass(frozen=True)
class ActuatorInfo(JointInfo):
    """An ``<actuator>`` of a ``<transmission>`` (an actuator hardware gets
    ``actuator1``, with its one joint's interfaces, as in ros2_control): a joint's
    fields, under ros2_control's other name."""


@dataclass(frozen=True)
class TransmissionInfo:
    name: str
    type: str  # its <plugin>
    joints: tuple[JointInfo, ...] = ()
    actuators: tuple[ActuatorInfo, ...] = ()
    parameters: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class SoftJointLimits:
    """A URDF joint's ``<safety_controller>``, within its position limits."""

    min_position: float
    max_position: float
    k_position: float
    k_velocity: float


@dataclass(frozen=True)
class AsyncParams:
    """``<properties><async .../></properties>`` (ros2_control's HardwareAsyncParams)."""

    thread_priority: int = 50
    scheduling_policy: str = "synchronized"
    cpu_affinity_cores: tuple[int, ...] = ()
    print_warnings: bool = True


@dataclass(frozen=True)
class HardwareInfo:
    """One ``<ros2_control>`` tag. ``rw_rate`` 0: the loop's rate."""

    name: str
    type: HardwareType
    hardware_plugin_name: str
    hardware_parameters: Mapping[str, str] = field(default_factory=dict)
    group: str = ""
    rw_rate: int = 0
    is_async: bool = False
    async_params: AsyncParams = AsyncParams()
    joints: tuple[ComponentInfo, ...] = ()
    sensors: tuple[ComponentInfo, ...] = ()
    gpios: tuple[ComponentInfo, ...] = ()
    transmissions: tuple[TransmissionInfo, ...] = ()
    mimic_joints: tuple[MimicJoint, ...] = ()
    limits: Mapping[str, JointLimits] = field(default_factory=dict)
    soft_limits: Mapping[str, SoftJointLimits] = field(default_factory=dict)
    original_xml: str = field(default="", repr=False, compare=False)


# --------------------------------------------------------------------------- the API


def parse(urdf_text: str, source: str = "robot_description") -> list[HardwareInfo]:
    """Every ``<ros2_control>`` tag of ``urdf_text``, in order (ros2_control's
    ``parse_control_resources_from_urdf``). ``source`` names the text in errors."""
    root = _read_xml(urdf_text, source)
    urdf = _read_urdf(root, source)
    tags = [child for child in root.children if child.tag == "ros2_control"]
    if not tags:
        raise ConfigurationError("no 'ros2_control' tag found in the URDF", file=source)
    return [_Hardware(tag, source, urdf_text).read(urdf) for tag in tags]


def joint_limits(urdf_text: str, source: str = "robot_description") -> dict[str, JointLimits]:
    """The limits of every joint of the URDF that is not fixed: its ``<limit>`` (a
    continuous joint has no position limits), and for a joint of a ``<ros2_control>``
    tag, what ros2_control makes of them with its interfaces' ``min``/``max`` (the
    narrowest, where the joint is in several tags)."""
    root = _read_xml(urdf_text, source)
    urdf = _read_urdf(root, source)
    limits = {name: joint.limits(source) for name, joint in urdf.items() if joint.type != "fixed"}
    described: dict[str, JointLimits] = {}
    if any(child.tag == "ros2_control" for child in root.children):
        for hardware in parse(urdf_text, source):
            for name, joint_limits_ in hardware.limits.items():
                known = described.get(name)
                described[name] = joint_limits_ if known is None else known.tightened(
                    joint_limits_)
    limits.update(described)
    return limits


# --------------------------------------------------------------------------- XML


@dataclass(eq=False)
class _Node:
    tag: str
    attrs: dict[str, str]
    line: int
    children: list[_Node] = field(default_factory=list)
    text_parts: list[str] = field(default_factory=list)

    @property
    def text(self) -> str:
        return "".join(self.text_parts).strip()

    def first(self, tag: str) -> _Node | None:
        return next((child for child in self.children if child.tag == tag), None)

    def all(self, tag: str) -> list[_Node]:
        return [child for child in self.children if child.tag == tag]

    def label(self) -> str:
        name = self.attrs.get("name")
        return f"<{self.tag}>" if name is None else f'<{self.tag} name="{name}">'


def _read_xml(text: str, source: str) -> _Node:
    if not text.strip():
        raise ConfigurationError("empty URDF passed to robot", file=source)
    parser = expat.ParserCreate()
    parser.buffer_text = True
    stack: list[_Node] = []
    roots: list[_Node] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        node = _Node(tag, attrs, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(node)
        stack.append(node)

    def end(tag: str) -> None:
        stack.pop()

    def chars(data: str) -> None:
        if stack:
            stack[-1].text_parts.append(data)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(text.strip(), True)
    except expat.ExpatError as exc:
        what = expat.ErrorString(exc.code) if exc.code is not None else str(exc)
        raise ConfigurationError(
            f"invalid URDF passed in to robot parser: {what} (line {exc.lineno}, column "
            f"{exc.offset + 1})", file=source, line=exc.lineno) from None
    if roots[0].tag != "robot":
        raise ConfigurationError(
            "the robot tag is not root element in URDF or sdf tag is not root element in SDF"
            f" (the root is <{roots[0].tag}>; rtcf reads URDF only)",
            file=source, line=roots[0].line)
    return roots[0]


def _as_bool(text: str) -> bool:
    lowered = text.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    raise ValueError(
        f"Input string : '{text.strip()}' is not a valid boolean value. Expected 'true' or "
        "'false'.")


def _as_float(text: str) -> float:
    """A finite number, as ros2_control's ``stod``."""
    value = float(text.strip())  # ValueError for what is not a number
    if not math.isfinite(value):
        raise ValueError(text)
    return value


# --------------------------------------------------------------------------- URDF


@dataclass(frozen=True)
class _UrdfJoint:
    """What ros2_control takes from a URDF ``<joint>`` (through urdfdom)."""

    name: str
    type: str
    line: int
    limit: tuple[float, float, float, float] | None  # lower, upper, velocity, effort
    mimic: tuple[str, float, float] | None  # joint, multiplier, offset
    safety: tuple[float, float, float, float] | None  # soft lower, upper, k_pos, k_vel

    def limits(self, source: str) -> JointLimits:
        """ros2_control's ``getJointLimits``; a velocity or effort of 0 is no limit."""
        if self.limit is None:
            return JointLimits()
        lower, upper, velocity, effort = self.limit
        positioned = self.type in ("revolute", "prismatic")
        try:
            return JointLimits(
                min_position=lower if positioned else -INF,
                max_position=upper if positioned else INF,
                max_velocity=abs(velocity) or INF,
                max_effort=abs(effort) or INF)
        except ConfigurationError as exc:
            raise ConfigurationError(f'<joint name="{self.name}"> <limit>: {exc.message}',
                                     file=source, line=self.line) from None


def _read_urdf(robot: _Node, source: str) -> dict[str, _UrdfJoint]:
    """The URDF's joints by name, with urdfdom's checks (ros2_control: "Failed to parse
    URDF file")."""

    def fail(node: _Node, what: str) -> ConfigurationError:
        return ConfigurationError(f"Failed to parse URDF file: {what}", file=source,
                                  line=node.line)

    if not robot.attrs.get("name"):
        raise fail(robot, "No name given for the robot.")
    links: set[str] = set()
    for tag in robot.all("link"):
        name = tag.attrs.get("name", "").strip()
        if not name:
            raise fail(tag, "No name given for the link.")
        if name in links:
            raise fail(tag, f"link '{name}' is not unique.")
        links.add(name)
    joints: dict[str, _UrdfJoint] = {}
    parent_of: dict[str, str] = {}
    for node in robot.all("joint"):
        joint = _read_urdf_joint(node, fail)
        if joint.name in joints:
            raise fail(node, f"joint '{joint.name}' is not unique.")
        joints[joint.name] = joint
        child = ""
        for end in ("parent", "child"):
            end_tag = node.first(end)
            child = end_tag.attrs.get("link", "").strip() if end_tag is not None else ""
            if not child:
                raise fail(node, f"No {end} link specified for Joint [{joint.name}].")
            if child not in links:
                raise fail(node, f"{end} link [{child}] of joint [{joint.name}] not found.")
        if child in parent_of:
            raise fail(node, f"child link [{child}] of joint [{joint.name}] already has a "
                             f"parent joint [{parent_of[child]}].")
        parent_of[child] = joint.name
    roots = sorted(links - set(parent_of))
    if len(roots) > 1:
        raise fail(robot, f"Two root links found: [{roots[0]}] and [{roots[1]}]")
    if links and not roots:
        raise fail(robot, "No root link found. The robot xml is not a valid tree.")
    return joints


def _read_urdf_joint(
    node: _Node, fail: Callable[[_Node, str], ConfigurationError]
) -> _UrdfJoint:
    name = node.attrs.get("name", "").strip()
    if not name:
        raise fail(node, "unnamed joint found")
    kind = node.attrs.get("type")
    if kind is None:
        raise fail(node, f"joint [{name}] has no type, check to see if it's a reference.")
    if kind not in _JOINT_TYPES:
        raise fail(node, f"Joint [{name}] has no known type [{kind}]")

    def number(tag: _Node, attr: str, default: float | None) -> float:
        text = tag.attrs.get(attr)
        if text is None:
            if default is None:
                raise fail(tag, f"joint [{name}] <{tag.tag}>: no {attr}")
            return default
        try:
            return _as_float(text)
        except ValueError:
            raise fail(tag, f"joint [{name}] <{tag.tag}>: {attr} value ({text}) is not a "
                            "valid float") from None

    limit = None
    tag = node.first("limit")
    if tag is not None:
        limit = (number(tag, "lower", 0.0), number(tag, "upper", 0.0),
                 number(tag, "velocity", None), number(tag, "effort", None))
    elif kind in ("revolute", "prismatic"):
        raise fail(node, f"Joint [{name}] is of type {kind.upper()} but it does not specify "
                         "limits")
    mimic = None
    tag = node.first("mimic")
    if tag is not None:
        if not tag.attrs.get("joint"):
            raise fail(tag, f"joint [{name}] <mimic>: no mimic joint specified")
        mimic = (tag.attrs["joint"].strip(), number(tag, "multiplier", 1.0),
                 number(tag, "offset", 0.0))
    safety = None
    tag = node.first("safety_controller")
    if tag is not None:
        safety = (number(tag, "soft_lower_limit", 0.0), number(tag, "soft_upper_limit", 0.0),
                  number(tag, "k_position", 0.0), number(tag, "k_velocity", None))
    return _UrdfJoint(name, kind, node.line, limit, mimic, safety)


# --------------------------------------------------------------------------- <ros2_control>


class _Hardware:
    """Reads one ``<ros2_control>`` tag; its errors name the tag."""

    def __init__(self, tag: _Node, source: str, urdf_text: str) -> None:
        self.tag = tag
        self.source = source
        self.urdf_text = urdf_text
        self.name = tag.attrs.get("name", "").strip()

    def error(self, node: _Node, what: str, *path: _Node) -> ConfigurationError:
        where = [self.tag.label(), *(n.label() for n in path)]
        if node is not self.tag and node not in path:
            where.append(node.label())
        return ConfigurationError(f"{' '.join(where)}: {what}", file=self.source,
                                  line=node.line)

    def attribute(self, node: _Node, attr: str, *path: _Node) -> str:
        value = node.attrs.get(attr)
        if value is None:
            name = node.attrs.get("name", "").strip()
            named = f" with name '{name}'" if name else ""
            raise self.error(node, f"no attribute '{attr}' in '{node.tag}' tag{named}", *path)
        return value.strip()

    def boolean(self, node: _Node, attr: str, *path: _Node) -> bool:
        try:
            return _as_bool(self.attribute(node, attr, *path))
        except ValueError as exc:
            raise self.error(node, f"{attr}: {exc}", *path) from None

    def params(self, node: _Node, context: str, *path: _Node) -> dict[str, str]:
        params: dict[str, str] = {}
        for param in node.all("param"):
            if "name" not in param.attrs:
                raise self.error(param, "no parameter name attribute set in param tag"
                                 + (f" for '{context}'" if context else ""), *path)
            params[param.attrs["name"].strip()] = param.text
        return params

    # ------------------------------------------------------------------ the tag

    def read(self, urdf: Mapping[str, _UrdfJoint]) -> HardwareInfo:
        tag = self.tag
        self.attribute(tag, "name")
        kind = self.attribute(tag, "type")
        if kind not in _HARDWARE_TYPES:
            raise self.error(tag, f"invalid hardware type '{kind}': expected 'system', "
                                  "'actuator' or 'sensor'")
        is_async = self.boolean(tag, "is_async") if "is_async" in tag.attrs else False
        thread_priority = self.positive(tag, "thread_priority", 50) if is_async else 50
        hardware: _Node | None = None
        plugin = ""
        joints: list[ComponentInfo] = []
        sensors: list[ComponentInfo] = []
        gpios: list[ComponentInfo] = []
        transmissions: list[_Node] = []
        async_params = AsyncParams(thread_priority=thread_priority)
        for child in tag.children:
            if child.tag == "hardware":
                hardware = child
                plugin = self.plugin(child)
            elif child.tag == "properties":
                async_params = self.async_params(child, async_params)
            elif child.tag == "joint":
                joints.append(self.component(child))
            elif child.tag == "sensor":
                sensors.append(self.component(child))
            elif child.tag == "gpio":
                gpios.append(self.component(child))
            elif child.tag == "transmission":
                transmissions.append(child)
            else:
                raise self.error(child, f"invalid tag name '{child.tag}'")
        if hardware is None:
            raise self.error(tag, f"Missing <hardware> tag of <ros2_control> element for "
                                  f"'{self.name}' in your URDF.")
        group = hardware.first("group")
        return self.limited(HardwareInfo(
            name=self.name, type=kind, hardware_plugin_name=plugin,  # type: ignore[arg-type]
            hardware_parameters=self.params(hardware, self.name, hardware),
            group=group.text if group is not None else "",
            rw_rate=self.rw_rate(), is_async=is_async, async_params=async_params,
            joints=tuple(joints), sensors=tuple(sensors), gpios=tuple(gpios),
            transmissions=tuple(self.transmission(t, kind, joints) for t in transmissions),
            original_xml=self.urdf_text), urdf)

    def plugin(self, hardware: _Node) -> str:
        plugin = hardware.first("plugin")
        if plugin is None:
            raise self.error(hardware, f"Missing <plugin> tag of <hardware> element for "
                                       f"'{self.name}' in your URDF.")
        if not plugin.text:
            raise self.error(plugin, "text not specified in the hardware plugin tag",
                             hardware)
        return plugin.text

    def positive(self, node: _Node, attr: str, default: int) -> int:
        text = node.attrs.get(attr)
        if text is None:
            return default
        if not _POSITIVE_INT.fullmatch(text.strip()):
            raise self.error(node, f'Could not parse {attr} tag in "{node.tag}". Got '
                                   f'"{text.strip()}", but expected a non-zero positive '
                                   "integer.")
        return int(text.strip())

    def rw_rate(self) -> int:
        text = self.tag.attrs.get("rw_rate", "0").strip()
        match = re.match(r"[+-]?[0-9]+", text)
        if match is None:
            raise self.error(self.tag, f'Could not parse rw_rate tag in "ros2_control". '
                                       f'Invalid value: "{text}", expected a positive integer.')
        rate = int(match.group())
        if not -_INT_MAX - 1 <= rate <= _INT_MAX:
            raise self.error(self.tag, f'Could not parse rw_rate tag in "ros2_control". Out '
                                       f'of range value: "{text}", expected a positive valid '
                                       "integer.")
        if rate < 0:
            raise self.error(self.tag, f'Could not parse rw_rate tag in "ros2_control". Got '
                                       f'"{rate}", but expected a positive integer.')
        return rate

    def async_params(self, properties: _Node, params: AsyncParams) -> AsyncParams:
        node = properties.first("async")
        if node is None:
            return params

        def bad(what: str) -> ConfigurationError:
            return self.error(node, f"Error parsing async tag: {what}", properties)

        cores, priority = params.cpu_affinity_cores, params.thread_priority
        if "affinity" in node.attrs:
            text = node.attrs["affinity"].strip()
            if not _INT_ARRAY.fullmatch(text):
                raise bad(f"affinity '{text}': String must be a flat array of integers: "
                          "starts with '[' and ends with ']', no nested arrays")
            cores = tuple(int(core) for core in re.findall(r"-?[0-9]+", text))
        policy = node.attrs.get("scheduling_policy", params.scheduling_policy).strip().lower()
        if "thread_priority" in node.attrs:
            text = node.attrs["thread_priority"].strip()
            if not _POSITIVE_INT.fullmatch(text):
                raise bad(f'Could not parse thread_priority tag in "async". Got "{text}", but '
                          "expected a non-zero positive integer.")
            priority = int(text)
        warnings = params.print_warnings
        if "print_warnings" in node.attrs:
            try:
                warnings = _as_bool(node.attrs["print_warnings"])
            except ValueError as exc:
                raise bad(str(exc)) from None
        return AsyncParams(priority, policy, cores, warnings)

    # ------------------------------------------------------------------ its children

    def component(self, node: _Node) -> ComponentInfo:
        name = self.attribute(node, "name")
        is_mimic = None
        if node.tag == "joint" and "mimic" in node.attrs:
            is_mimic = self.boolean(node, "mimic")
        enable = True
        limits = node.first("limits")
        if limits is not None and node.tag != "gpio":
            enable = self.boolean(limits, "enable", node)
        return ComponentInfo(
            name=name, type=node.tag,  # type: ignore[arg-type]
            command_interfaces=tuple(self.interface(i, node, enable)
                                     for i in node.all("command_interface")),
            state_interfaces=tuple(self.interface(i, node, enable)
                                   for i in node.all("state_interface")),
            parameters=self.params(node, name, node), is_mimic=is_mimic, enable_limits=enable)

    def interface(self, node: _Node, component: _Node, enable: bool) -> InterfaceInfo:
        name = self.attribute(node, "name", component)
        params = self.params(node, component.attrs.get("name", ""), component, node)
        limits = node.first("limits")
        if limits is not None:
            enable = self.boolean(limits, "enable", component, node) and enable
        size = 1
        if "size" in node.attrs:
            size = self.positive_size(node, component)
        return InterfaceInfo(
            name=name, min=params.get("min", ""), max=params.get("max", ""),
            initial_value=params.get("initial_value", ""),
            data_type=node.attrs.get("data_type", "double").strip(), size=size,
            enable_limits=enable, parameters=params)

    def positive_size(self, node: _Node, component: _Node) -> int:
        text = node.attrs["size"].strip()
        if not _POSITIVE_INT.fullmatch(text):
            raise self.error(node, f'Could not parse size tag in "{node.tag}". Got "{text}", '
                                   "but expected a non-zero positive integer.", component)
        return int(text)

    def transmission(
        self, node: _Node, kind: str, joints: list[ComponentInfo]
    ) -> TransmissionInfo:
        name = self.attribute(node, "name")
        plugin = node.first("plugin")
        if plugin is None:
            raise self.error(node, f"Missing <plugin> tag of <transmission> element for "
                                   f"'{name}' in your URDF.")
        by_name = {joint.name: joint for joint in joints}
        parts: list[JointInfo] = []
        for part in node.all("joint"):
            joint, role, reduction, offset, read_only = self.transmission_part(part, node)
            found = by_name.get(joint)
            if found is None:
                raise self.error(part, f"Error while parsing '{self.name}'. Transmission "
                                       f"'{name}' declared joint '{joint}' is not "
                                       f"available in component '{self.name}'.", node)
            parts.append(JointInfo(
                joint, role, tuple(i.name for i in found.state_interfaces),
                tuple(i.name for i in found.command_interfaces), reduction, offset, read_only))
        actuators = []
        for part in node.all("actuator"):
            actuator, role, reduction, offset, read_only = self.transmission_part(part, node)
            actuators.append(ActuatorInfo(actuator, role, (), (), reduction, offset, read_only))
        if kind == "actuator":
            if len(parts) != 1:
                raise self.error(node, f"Error while parsing '{self.name}'. There should be "
                                       "exactly one joint defined in this component but found "
                                       f"{len(parts)}.")
            actuators.append(ActuatorInfo("actuator1", "actuator1", parts[0].state_interfaces,
                                          parts[0].command_interfaces))
        return TransmissionInfo(name, plugin.text, tuple(parts), tuple(actuators),
                                self.params(node, name, node))

    def transmission_part(
        self, node: _Node, transmission: _Node
    ) -> tuple[str, str, float, float, bool]:
        """(name, role, mechanical_reduction, offset, read_only) of a joint or actuator."""
        name = self.attribute(node, "name", transmission)
        role = self.attribute(node, "role", transmission)
        read_only = (self.boolean(node, "read_only", transmission)
                     if "read_only" in node.attrs else False)
        numbers = []
        for tag, default in (("mechanical_reduction", 1.0), ("offset", 0.0)):
            child = node.first(tag)
            if child is None or not child.text:
                numbers.append(default)
                continue
            try:
                numbers.append(_as_float(child.text))
            except ValueError:
                raise self.error(child, f"<{tag}> is '{child.text}'; give a number",
                                 transmission, node) from None
        return name, role, numbers[0], numbers[1], read_only

    # ------------------------------------------------------------------ against the URDF

    def limited(self, info: HardwareInfo, urdf: Mapping[str, _UrdfJoint]) -> HardwareInfo:
        """Mimic joints, fixed joints and the limits: what ros2_control checks against the
        URDF model."""
        nodes = {n.attrs.get("name", "").strip(): n for n in self.tag.all("joint")}
        index = {joint.name: i for i, joint in enumerate(info.joints)}
        mimics: list[MimicJoint] = []
        limits: dict[str, JointLimits] = {}
        soft: dict[str, SoftJointLimits] = {}
        for i, joint in enumerate(info.joints):
            node = nodes[joint.name]
            described = urdf.get(joint.name)
            if described is None:
                raise self.error(node, f"Joint '{joint.name}' not found in URDF")
            if described.mimic is None and joint.is_mimic is True:
                raise self.error(node, f"Joint '{joint.name}' has no mimic information in "
                                       "the URDF")
            if described.mimic is not None and joint.is_mimic is not False:
                if joint.command_interfaces:
                    raise self.error(node, f"Joint '{joint.name}' has mimic attribute not set "
                                           "to false: Activated mimic joints cannot have "
                                           "command interfaces.")
                followed, multiplier, offset = described.mimic
                if followed not in index:
                    raise self.error(node, f"Mimic joint '{followed}' not found in "
                                           "<ros2_control> tag")
                mimics.append(MimicJoint(joint.name, followed, i, index[followed], multiplier,
                                         offset))
            if described.type == "fixed":
                raise self.error(node, f"Joint '{joint.name}' is of type 'fixed'. Fixed "
                                       "joints do not make sense in ros2_control.")
            limits[joint.name] = self.narrowed(described.limits(self.source), joint, node)
            if described.safety is not None:
                lower, upper, k_position, k_velocity = described.safety
                hard = limits[joint.name]
                soft[joint.name] = SoftJointLimits(
                    max(lower, hard.min_position), min(upper, hard.max_position), k_position,
                    k_velocity)
        return replace(info, mimic_joints=tuple(mimics), limits=limits, soft_limits=soft)

    def narrowed(self, limits: JointLimits, joint: ComponentInfo, node: _Node) -> JointLimits:
        """ros2_control's ``update_interface_limits``: the command interfaces' ``min`` and
        ``max`` narrow the URDF's limits where ``enable_limits`` is on; where it is off,
        that interface's kind has no limit."""
        if not joint.enable_limits:
            return JointLimits()
        values = {"min_position": limits.min_position, "max_position": limits.max_position,
                  "max_velocity": limits.max_velocity,
                  "max_acceleration": limits.max_acceleration, "max_effort": limits.max_effort}
        for interface in joint.command_interfaces:
            kind = interface.name
            if kind not in ("position", "velocity", "effort", "acceleration"):
                continue
            where = next(n for n in node.all("command_interface")
                         if n.attrs.get("name", "").strip() == kind)
            if not interface.enable_limits:
                if kind == "position":
                    values["min_position"], values["max_position"] = -INF, INF
                else:
                    values[f"max_{kind}"] = INF
                continue
            low, high = (self.bound(interface, key, node, where) for key in ("min", "max"))
            if kind == "position":
                values["min_position"] = max(values["min_position"], low)
                values["max_position"] = min(values["max_position"], high)
            elif kind == "acceleration":  # rtcf has no deceleration limit: the max only
                values["max_acceleration"] = min(values["max_acceleration"], high)
            else:
                values[f"max_{kind}"] = min(values[f"max_{kind}"], abs(low), high)
        try:
            return JointLimits(**values)
        except ConfigurationError as exc:
            raise self.error(node, f"the limits of joint '{joint.name}' from the URDF and its "
                                   f"command interfaces: {exc.message}") from None

    def bound(self, interface: InterfaceInfo, key: str, joint: _Node, node: _Node) -> float:
        text = interface.min if key == "min" else interface.max
        if not text:
            return -INF if key == "min" else INF
        try:
            return _as_float(text)
        except ValueError:
            raise self.error(node, f"Error parsing the limits for the interface: "
                                   f"{interface.name} from the tags [min: '{interface.min}' "
                                   f"and max: '{interface.max}'] within ros2_control tag "
                                   "inside the URDF: give numbers", joint) from None


