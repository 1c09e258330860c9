"""A component's face in a ROS 2 graph: a node of its name with its parameters and logger.

A composed ROS 2 node shows up under its own name and namespace, with its
parameters and logger services, although it lives in a container process. A
component does the same: with ``rtcf launch --middleware ros2`` the supervisor makes
a node per component; with ``rt_launcher`` the launcher's own node is the face.

* Parameters the component read at configure time (its private parameters from the
  launch file) are declared **read-only**: changing them later would do nothing.
* Tunable parameters (``self.params.declare``) are declared with their type,
  description and range (``ros2 param describe`` shows them). A change through the
  standard ``set_parameters`` services is validated here, in the supervisor, then
  applied in the worker between two iterations.
* ``~/get_logger_levels`` and ``~/set_logger_levels`` (rcl_interfaces, what
  ``ros2 service call`` and rqt use) change the component's level *in the worker*,
  so that filtered records never take room in the log ring.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Protocol

from ._errors import RtcfError
from ._tunables import TunableSpec

# the ROS 2 logger levels (rcutils): UNSET, DEBUG, INFO, WARN, ERROR, FATAL
ROS2_LEVELS = (0, 10, 20, 30, 40, 50)
_INT_BOUND = 2**63 - 1


class Tuner(Protocol):
    """Where changes go: the supervisor's WorkerRunner, or a launcher's link to its runner."""

    def set_parameter(self, component: str, name: str, value: Any) -> Any: ...

    def set_log_level(self, component: str, level: int | str) -> None: ...


def ros_logger_name(component: str) -> str:
    """ROS 2's logger name of a node: '/rtcf/sum1' -> 'rtcf.sum1'."""
    return ".".join(p for p in component.split("/") if p)


class ComponentFace:
    """Declares a component's parameters on ``node`` and serves its logger levels."""

    def __init__(self, node: Any, info: dict[str, Any], tuner: Tuner, default_level: int) -> None:
        from rcl_interfaces.srv import GetLoggerLevels, SetLoggerLevels

        self.node = node
        self.name = str(info["name"])
        self.logger = ros_logger_name(self.name)
        self.tuner = tuner
        self.default_level = default_level
        self.level = int(info.get("log_level") or default_level)
        self.specs = {
            t["name"]: TunableSpec.from_dict({k: v for k, v in t.items() if k != "value"})
            for t in info.get("tunables", [])
        }
        for t in info.get("tunables", []):
            if node.has_parameter(t["name"]):  # a launcher's -p override, declared untyped
                node.undeclare_parameter(t["name"])
            node.declare_parameter(t["name"], t["value"], _descriptor(self.specs[t["name"]]))
        for name, value in _flatten(info.get("parameters") or {}):
            if name in self.specs or node.has_parameter(name):
                continue
            node.declare_parameter(name, _ros_value(value), _read_only(value))
        node.add_on_set_parameters_callback(self._on_set)
        self._services = [
            node.create_service(GetLoggerLevels, "~/get_logger_levels", self._get_levels),
            node.create_service(SetLoggerLevels, "~/set_logger_levels", self._set_levels),
        ]

    # -- parameters ------------------------------------------------------------------
    def _on_set(self, params: list[Any]) -> Any:
        from rcl_interfaces.msg import SetParametersResult

        changes = []
        for p in params:
            spec = self.specs.get(p.name)
            if spec is None:
                return SetParametersResult(
                    successful=False,
                    reason=f"component {self.name!r}: parameter {p.name!r} was read at "
                    "configure time and cannot change while running; declare it with "
                    "self.params.declare() to make it tunable",
                )
            try:
                changes.append((p.name, spec.validate(p.value)))
            except RtcfError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        try:  # all valid: only now does any of them go to the worker
            for name, value in changes:
                self.tuner.set_parameter(self.name, name, value)
        except RtcfError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    # -- logger levels ---------------------------------------------------------------
    def _get_levels(self, request: Any, response: Any) -> Any:
        from rcl_interfaces.msg import LoggerLevel

        names = list(request.names) or [self.logger]
        response.levels = [
            LoggerLevel(name=n, level=self.level if n == self.logger else 0) for n in names
        ]
        return response

    def _set_levels(self, request: Any, response: Any) -> Any:
        from rcl_interfaces.msg import SetLoggerLevelsResult

        results = []
        for item in request.levels:
            if item.name != self.logger:
                results.append(SetLoggerLevelsResult(
                    successful=False,
                    reason=f"this node's component logs as {self.logger!r}, not {item.name!r}",
                ))
            elif item.level not in ROS2_LEVELS:
                results.append(SetLoggerLevelsResult(
                    successful=False,
                    reason=f"level {item.level} is not one of {ROS2_LEVELS} (UNSET..FATAL)",
                ))
            else:
                level = item.level or self.default_level  # UNSET: back to the runner's
                try:
                    self.tuner.set_log_level(self.name, level)
                except RtcfError as exc:
                    results.append(SetLoggerLevelsResult(successful=False, reason=str(exc)))
                    continue
                self.level = level
                results.append(SetLoggerLevelsResult(successful=True, reason=""))
        response.results = results
        return response

    def close(self) -> None:
        for srv in self._services:
            self.node.destroy_service(srv)
        self._services = []


def _descriptor(spec: TunableSpec) -> Any:
    from rcl_interfaces.msg import (
        FloatingPointRange,
        IntegerRange,
        ParameterDescriptor,
        ParameterType,
    )

    kinds = {
        "bool": ParameterType.PARAMETER_BOOL,
        "int": ParameterType.PARAMETER_INTEGER,
        "float": ParameterType.PARAMETER_DOUBLE,
        "str": ParameterType.PARAMETER_STRING,
    }
    d = ParameterDescriptor(
        name=spec.name, type=kinds[spec.type], description=spec.description, read_only=False
    )
    if spec.choices is not None:
        d.additional_constraints = "one of: " + ", ".join(repr(c) for c in spec.choices)
    if spec.min is not None or spec.max is not None:
        if spec.type == "float":
            d.floating_point_range = [FloatingPointRange(
                from_value=float(spec.min if spec.min is not None else -float("inf")),
                to_value=float(spec.max if spec.max is not None else float("inf")),
                step=0.0,
            )]
        else:
            d.integer_range = [IntegerRange(
                from_value=int(spec.min if spec.min is not None else -_INT_BOUND),
                to_value=int(spec.max if spec.max is not None else _INT_BOUND),
                step=0,
            )]
    return d


def _read_only(value: Any) -> Any:
    from rcl_interfaces.msg import ParameterDescriptor

    return ParameterDescriptor(
        read_only=True,
        dynamic_typing=True,
        description="read by the component at configure time",
    )


def _flatten(tree: dict[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    """'/ns/c/gains/kp' style subtrees as ROS 2 parameter names: 'gains.kp'."""
    for key, value in sorted(tree.items()):
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            yield from _flatten(value, name + ".")
        else:
            yield name, value


def _ros_value(value: Any) -> Any:
    """A value ROS 2 parameters can hold; anything else is shown as its text."""
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)) and value:
        for kind in (bool, int, float, str):
            if all(type(v) is kind for v in value):
                return list(value)
    return repr(value)
