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
* It is a managed (lifecycle) node, as ros2_control's controllers are: ``~/get_state``,
  ``~/change_state``, ``~/get_available_states``, ``~/get_available_transitions`` and
  ``~/get_transition_graph`` (lifecycle_msgs), and ``~/transition_event``. The state
  machine is the runner's (``rtcf._core._lifecycle``); the face asks it, so what
  the services say is what the loop does.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any, Protocol

from .._core._errors import RtcfError
from .._core._lifecycle import (
    STATE_IDS,
    STATE_LABELS,
    TransitionDescription,
    TransitionOutcome,
    available_transitions,
    inferred,
    refused,
    transition_graph,
)
from .._core._tunables import TunableSpec, Tuner

# the ROS 2 logger levels (rcutils): UNSET, DEBUG, INFO, WARN, ERROR, FATAL
ROS2_LEVELS = (0, 10, 20, 30, 40, 50)
_INT_BOUND = 2**63 - 1


def ros_logger_name(component: str) -> str:
    """ROS 2's logger name of a node: '/rtcf/sum1' -> 'rtcf.sum1'."""
    return ".".join(p for p in component.split("/") if p)


class Lifecycle(Protocol):
    """Where the face's lifecycle requests go: the supervisor's WorkerRunner, or a
    launcher's link to its runner. Both may block (never in the loop's process)."""

    def lifecycle_state(self, component: str) -> str: ...

    def change_state(self, component: str, transition: int | str) -> TransitionOutcome: ...


class ComponentFace:
    """Declares a component's parameters on ``node``, serves its logger levels and, given
    ``lifecycle``, its lifecycle services."""

    def __init__(
        self,
        node: Any,
        info: dict[str, Any],
        tuner: Tuner,
        default_level: int,
        lifecycle: Lifecycle | None = None,
        *,
        announced: bool = False,
    ) -> None:
        from rcl_interfaces.srv import GetLoggerLevels, SetLoggerLevels

        self.node = node
        self.name = str(info["name"])
        self.logger = ros_logger_name(self.name)
        self.tuner = tuner
        self.default_level = default_level
        self.level = int(info.get("log_level") or default_level)
        self.specs: dict[str, TunableSpec] = {}
        self.declare_tunables(info)
        for name, value in _flatten(info.get("parameters") or {}):
            if name in self.specs or node.has_parameter(name):
                continue
            node.declare_parameter(name, ros_value(value), read_only(value))
        node.add_on_set_parameters_callback(self._on_set)
        self._services = [
            node.create_service(GetLoggerLevels, "~/get_logger_levels", self._get_levels),
            node.create_service(SetLoggerLevels, "~/set_logger_levels", self._set_levels),
        ]
        self.lifecycle = (
            LifecycleFace(
                node, self.name, lifecycle, str(info.get("lifecycle") or "unknown"), announced
            )
            if lifecycle is not None
            else None
        )

    # -- parameters ------------------------------------------------------------------
    def declare_tunables(self, info: dict[str, Any]) -> None:
        """The component's tunables as parameters of its node: when it is loaded, and
        after its first configure when it was loaded unconfigured (they are declared
        there). A parameter of the same name, read-only as a private parameter is, stays
        so (its value then changes by a cleanup and configure)."""
        from rclpy.exceptions import ParameterImmutableException

        node = self.node
        for t in info.get("tunables", []):
            name = t["name"]
            if name in self.specs:
                continue
            spec = TunableSpec.from_dict({k: v for k, v in t.items() if k != "value"})
            if node.has_parameter(name):  # a launcher's -p override, declared untyped
                try:
                    node.undeclare_parameter(name)
                except ParameterImmutableException:
                    continue
            self.specs[name] = spec
            node.declare_parameter(name, t["value"], _descriptor(spec))

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
        if self.lifecycle is not None:
            self.lifecycle.close()


class LifecycleFace:
    """The lifecycle_msgs services and transition events of one component's node.

    ``change_state`` takes the transition's label when it has one, else its id (as
    rclpy's lifecycle nodes do), and answers ``success`` once the runner has run the
    hooks between two iterations; the reason of a failure goes to the log (the
    response has no field for it). Every state change is published on
    ``~/transition_event``, one message per step (``deactivate``, then
    ``transition_success``), as rcl_lifecycle does. ``announced``: the backend reports
    every transition to :meth:`publish` itself (the supervisor's listeners), so the
    service does not publish them again.
    """

    def __init__(
        self, node: Any, name: str, backend: Lifecycle, state: str, announced: bool = False
    ) -> None:
        from lifecycle_msgs.msg import TransitionEvent
        from lifecycle_msgs.srv import (
            ChangeState,
            GetAvailableStates,
            GetAvailableTransitions,
            GetState,
        )

        self.node = node
        self.name = name
        self.backend = backend
        self.announced = announced
        self._lock = threading.Lock()
        self.known = STATE_IDS.get(state, 0)  # the last state it published or answered
        self.epoch = 0  # counts changes through this face: an older poll's answer is stale
        # transient local: a subscriber that comes late (a lifecycle manager started
        # after the component, a test whose discovery lags) still gets the last
        # transitions; volatile subscribers (the default) match it as well
        from rclpy.qos import DurabilityPolicy, QoSProfile

        self.events = node.create_publisher(
            TransitionEvent, "~/transition_event",
            QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )
        self._services = [
            node.create_service(GetState, "~/get_state", self._get_state),
            node.create_service(ChangeState, "~/change_state", self._change_state),
            node.create_service(
                GetAvailableStates, "~/get_available_states", self._get_available_states
            ),
            node.create_service(
                GetAvailableTransitions,
                "~/get_available_transitions",
                self._get_available_transitions,
            ),
            node.create_service(
                GetAvailableTransitions, "~/get_transition_graph", self._get_transition_graph
            ),
        ]

    def state(self) -> int:
        state = STATE_IDS.get(self.backend.lifecycle_state(self.name), 0)
        self.seen(state)
        return state

    def seen(self, state: int, epoch: int | None = None) -> None:
        """A state learned from outside (the runner activated what it loaded): publish
        the transition that leads there, if one does. ``epoch``: the face's epoch when
        the state was asked for; if it changed since, the answer is stale."""
        with self._lock:
            if epoch is not None and epoch != self.epoch:
                return
            known, self.known = self.known, state
        if state != known and known != 0:
            outcome = inferred(known, state)
            if outcome is not None:
                self._publish(outcome)

    def publish(self, outcome: TransitionOutcome) -> None:
        """The events of a transition the runner ran (and its state from now on)."""
        with self._lock:
            self.epoch += 1
            if outcome.result != "refused":
                self.known = outcome.end
        self._publish(outcome)

    def _publish(self, outcome: TransitionOutcome) -> None:
        from lifecycle_msgs.msg import TransitionEvent

        stamp = self.node.get_clock().now().nanoseconds
        for step in outcome.steps():
            msg = TransitionEvent(timestamp=stamp)
            _fill(msg.transition, msg.start_state, msg.goal_state, step)
            self.events.publish(msg)

    # -- services --------------------------------------------------------------------
    def _get_state(self, request: Any, response: Any) -> Any:
        state = self.state()
        response.current_state.id = state
        response.current_state.label = STATE_LABELS[state]
        return response

    def _change_state(self, request: Any, response: Any) -> Any:
        t = request.transition
        transition: int | str = t.label if t.label else int(t.id)
        with self._lock:
            self.epoch += 1  # a poll answered before this change ends is stale
        try:
            outcome = self.backend.change_state(self.name, transition)
        except RtcfError as exc:
            outcome = refused(0, str(exc))
        if outcome.result == "refused":
            self.node.get_logger().warning(
                f"lifecycle: {transition!r} refused: {outcome.reason}"
            )
        elif not self.announced:
            self.publish(outcome)
        response.success = outcome.ok
        return response

    def _get_available_states(self, request: Any, response: Any) -> Any:
        from lifecycle_msgs.msg import State

        response.available_states = [State(id=i, label=lb) for i, lb in STATE_LABELS.items()]
        return response

    def _get_available_transitions(self, request: Any, response: Any) -> Any:
        response.available_transitions = _descriptions(available_transitions(self.state()))
        return response

    def _get_transition_graph(self, request: Any, response: Any) -> Any:
        response.available_transitions = _descriptions(transition_graph())
        return response

    def close(self) -> None:
        for srv in self._services:
            self.node.destroy_service(srv)
        self._services = []
        self.node.destroy_publisher(self.events)


def _fill(transition: Any, start: Any, goal: Any, step: TransitionDescription) -> None:
    transition.id, transition.label = step.transition, step.label
    start.id, start.label = step.start, STATE_LABELS[step.start]
    goal.id, goal.label = step.goal, STATE_LABELS[step.goal]


def _descriptions(steps: list[TransitionDescription]) -> list[Any]:
    from lifecycle_msgs.msg import TransitionDescription as Description

    out = []
    for step in steps:
        d = Description()
        _fill(d.transition, d.start_state, d.goal_state, step)
        out.append(d)
    return out


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


def read_only(value: Any) -> Any:
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


def ros_value(value: Any) -> Any:
    """A value ROS 2 parameters can hold; anything else is shown as its text."""
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)) and value:
        for kind in (bool, int, float, str):
            if all(type(v) is kind for v in value):
                return list(value)
    return repr(value)
