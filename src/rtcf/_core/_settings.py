"""The runner's parameters, with the names and meanings of the original rt_runner."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ._booleans import parse_bool
from ._errors import ConfigurationError
from ._names import validate_name

MODES = ("wait_for_components", "no_wait", "wait_for_trigger")
RELIABILITIES = ("reliable", "best_effort")
DURABILITIES = ("volatile", "transient_local")
WAIT_POLICIES = ("absolute", "relative")
LOCKS = ("none", "structure", "all")  # what a running runner refuses (docs/security.md)
DEFAULT_FREQUENCY = 1.0


@dataclass
class RunnerSettings:
    """How a runner runs its loop.

    ``mode``: ``no_wait`` starts the loop as soon as a component is loaded and
    restarts it after every load and unload; ``wait_for_components`` starts it once
    ``num_components_expected`` components are loaded; ``wait_for_trigger`` starts
    it on ``activate()`` (a service call under ROS).
    ``wait_policy``: ``absolute`` keeps every iteration on the grid of the first
    (late iterations run back to back until the loop has caught up); ``relative``
    re-anchors the grid after an overrun: the next start is one period after it ended.
    ``ros_mapping_whitelist``/``ros_mapping_blacklist``: full-match regexes on topic
    names that choose the ports mapped to middleware topics.
    ``ros_qos_depth``/``ros_qos_reliability``/``ros_qos_durability``: the QoS of the
    mapped topics (ROS 1 uses the depth as queue_size and transient_local as latch).
    ``ros_qos_deadline``: ROS 2 mapped inputs with a deadline also request it as their
    QoS ``deadline`` and liveliness lease (their publishers must offer as much, or DDS
    does not connect them).
    ``iteration_info``: publish ``~/iteration_info`` (one message per iteration).
    ``action_max_goal_bytes``: the largest goal (its CDR bytes) a mapped action takes;
    a larger one is rejected.
    ``controller_manager``: under ROS 2, the name (relative to the runner's namespace,
    or absolute) whose ``list_controllers`` and ``switch_controller`` services a
    ros2_control controller manager's tools call; empty: none.
    ``max_consecutive_overruns``/``max_overruns_per_second``: watchdogs that end the
    loop through the safe-stop path past that many overruns (0: off).
    ``max_let_overruns``: a watchdog that ends the loop through the safe-stop path
    when a lane on logical execution time has not finished more than that many of
    its windows in a run (0: off; each is counted and reported either way).
    ``hook_timeout``: seconds a ``configure``/``start``/``stop``/``cleanup``/``safe_stop``
    hook may take; past it the supervisor names the hook and ends the run.
    ``heartbeat_timeout``: seconds the worker waits for a sign of life from its
    supervisor while the loop runs before it stops through the safe-stop path (0: off).
    ``lanes``: where the lanes other than main run, ``"name:cpu[:priority], ..."`` (or a
    mapping of name to ``{"cpu": .., "priority": ..}``); a lane not named gets a CPU of
    its own where one is left (:func:`lane_placement`).
    ``lock``: ``none``; ``structure`` (once the loop runs, load, unload and lifecycle
    requests are refused); ``all`` (tunables too). ``allowed_modules``: full-match
    regexes (a list, or one string split at whitespace) that a loaded component's
    module must match, checked before it is imported; empty: any module.
    ``robot_description`` (the URDF's text) or ``robot_description_file`` (its path):
    the robot whose ``<ros2_control>`` hardware the loop reads and writes
    (docs/hardware.md); ``hardware_components_initial_state.unconfigured`` /
    ``.inactive``: hardware left in that state at start (the others are activated), as
    ros2_control's controller manager reads them.
    """

    mode: str = "no_wait"
    num_components_expected: int = 0
    frequency: float = DEFAULT_FREQUENCY
    wait_policy: str = "absolute"
    ros_mapping_whitelist: str = ""
    ros_mapping_blacklist: str = ""
    lock_memory: bool = False
    safe_heap_size_kB: int = 0
    safe_stack_size_kB: int = 0
    cpu_affinity_mask: int = 0  # 0: leave the affinity as it is
    priority: int = 80
    use_sim_time: bool = False  # the loop follows the middleware's /clock
    # what ``ros2 topic pub/echo`` use by default, so the usual tools connect
    ros_qos_depth: int = 10
    ros_qos_reliability: str = "reliable"
    ros_qos_durability: str = "volatile"
    ros_qos_deadline: bool = False
    iteration_info: bool = True
    action_max_goal_bytes: int = 256 * 1024  # a 100-point 7-joint FollowJointTrajectory: ~20 KiB
    controller_manager: str = "controller_manager"
    max_consecutive_overruns: int = 0
    max_let_overruns: int = 0
    max_overruns_per_second: int = 0
    hook_timeout: float = 10.0
    heartbeat_timeout: float = 5.0
    lanes: str = ""
    lock: str = "none"
    allowed_modules: tuple[str, ...] = ()
    robot_description: str = field(default="", repr=False)
    robot_description_file: str = ""
    hardware_initial_unconfigured: tuple[str, ...] = ()
    hardware_initial_inactive: tuple[str, ...] = ()
    notes: list[str] = field(default_factory=list, compare=False)

    def __post_init__(self) -> None:
        self.validate()

    @property
    def period_ns(self) -> int:
        return round(1e9 / self.frequency)

    def allows_module(self, module: str) -> bool:
        """Whether ``allowed_modules`` lets a component of ``module`` load."""
        return not self.allowed_modules or any(
            re.fullmatch(p, module) for p in self.allowed_modules)

    def maps_to_ros(self, topic: str) -> bool:
        """Whether ``topic`` matches the whitelist and not the blacklist."""
        if not self.ros_mapping_whitelist or not re.fullmatch(self.ros_mapping_whitelist, topic):
            return False
        return not (self.ros_mapping_blacklist and re.fullmatch(self.ros_mapping_blacklist, topic))

    def validate(self, where: str = "runner") -> None:
        def bad(msg: str) -> ConfigurationError:
            return ConfigurationError(f"{where}: {msg}")

        if self.mode not in MODES:
            raise bad(f"mode {self.mode!r} is unknown; use one of {', '.join(MODES)}")
        if self.mode == "wait_for_components" and self.num_components_expected <= 0:
            raise bad("mode 'wait_for_components' needs num_components_expected, a number above 0")
        if not (self.frequency > 0 and self.frequency < 1e6):
            raise bad(f"frequency {self.frequency!r} Hz is not feasible; use a value in (0, 1e6)")
        if self.wait_policy not in WAIT_POLICIES:
            raise bad(f"wait_policy {self.wait_policy!r} is unknown; use absolute or relative")
        for key in ("ros_mapping_whitelist", "ros_mapping_blacklist"):
            pattern = getattr(self, key)
            try:
                re.compile(pattern)
            except re.error as exc:
                raise bad(f"{key} {pattern!r} is not a valid regular expression: {exc}") from None
        for key in ("safe_heap_size_kB", "safe_stack_size_kB", "cpu_affinity_mask"):
            if getattr(self, key) < 0:
                raise bad(f"{key} must not be negative")
        if self.controller_manager:
            problem = validate_name(self.controller_manager, what="controller_manager")
            if problem or self.controller_manager.startswith("~"):
                raise bad(
                    f"controller_manager {self.controller_manager!r} is not a node name: give "
                    "a name such as controller_manager or /robot/controller_manager, or "
                    "'' for none"
                )
        if self.ros_qos_depth < 1:
            raise bad(f"ros_qos_depth {self.ros_qos_depth} must be at least 1")
        if not 1024 <= self.action_max_goal_bytes <= 64 * 1024 * 1024:
            raise bad(f"action_max_goal_bytes {self.action_max_goal_bytes} must be between "
                      "1024 and 67108864 (64 MiB)")
        if self.ros_qos_reliability not in RELIABILITIES:
            raise bad(
                f"ros_qos_reliability {self.ros_qos_reliability!r} is unknown; "
                "use reliable or best_effort"
            )
        if self.ros_qos_durability not in DURABILITIES:
            raise bad(
                f"ros_qos_durability {self.ros_qos_durability!r} is unknown; "
                "use volatile or transient_local"
            )
        for key in ("max_consecutive_overruns", "max_overruns_per_second", "max_let_overruns"):
            if getattr(self, key) < 0:
                raise bad(f"{key} must not be negative (0 turns the watchdog off)")
        if not self.hook_timeout > 0:
            raise bad(f"hook_timeout {self.hook_timeout!r} s must be above 0")
        if self.heartbeat_timeout < 0:
            raise bad(f"heartbeat_timeout {self.heartbeat_timeout!r} s must not be negative")
        if not 1 <= self.priority <= 99:
            raise bad(f"priority {self.priority} is out of range; SCHED_FIFO takes 1 to 99")
        if self.lock not in LOCKS:
            raise bad(f"lock {self.lock!r} is unknown; use one of {', '.join(LOCKS)}")
        for pattern in self.allowed_modules:
            try:
                re.compile(pattern)
            except re.error as exc:
                raise bad(f"allowed_modules {pattern!r} is not a valid regular expression: "
                          f"{exc}") from None
        try:
            parse_lanes(self.lanes)
        except ValueError as exc:
            raise bad(f"lanes {self.lanes!r}: {exc}") from None

    @classmethod
    def from_params(cls, params: Mapping[str, Any], where: str = "runner") -> RunnerSettings:
        """Read settings from a runner node's private parameters (unknown ones noted)."""
        notes: list[str] = []
        values: dict[str, Any] = {}
        for key, value in _flat_initial_state(params).items():
            if key not in _CONVERTERS:
                if key not in _IGNORED:
                    notes.append(
                        f"{where}: unknown parameter {key!r} ignored; known are "
                        + ", ".join(sorted(_CONVERTERS))
                    )
                continue
            try:
                values[_FIELDS.get(key, key)] = _CONVERTERS[key](value)
            except (TypeError, ValueError):
                raise ConfigurationError(
                    f"{where}: parameter {key!r} has value {value!r}, which is not {_EXPECTED[key]}"
                ) from None
        if "mode" not in values:
            notes.append(f"{where}: no mode given, using 'no_wait'")
        if "frequency" not in values:
            notes.append(f"{where}: no frequency given, using {DEFAULT_FREQUENCY} Hz")
        if "mode" in values:
            values["mode"] = values["mode"].lower()
        settings = cls.__new__(cls)
        for f in cls.__dataclass_fields__.values():
            if f.name != "notes":
                setattr(settings, f.name, values.get(f.name, cls._default(f.name)))
        settings.notes = notes
        settings.validate(where)
        return settings

    @staticmethod
    def _default(name: str) -> Any:
        return RunnerSettings.__dataclass_fields__[name].default


def _to_bool(v: Any) -> bool:
    try:
        return parse_bool(v, "")  # the caller names the setting
    except ConfigurationError:
        raise ValueError(v) from None


def _to_int(v: Any) -> int:
    if isinstance(v, bool):
        raise ValueError(v)
    if isinstance(v, str):
        text = v.strip().lower()
        return int(text, 16) if text.startswith("0x") else int(text, 10)
    if isinstance(v, float) and not v.is_integer():
        raise ValueError(v)
    return int(v)


def _to_float(v: Any) -> float:
    if isinstance(v, bool):
        raise ValueError(v)
    return float(v)


def _to_str(v: Any) -> str:
    if not isinstance(v, str):
        raise ValueError(v)
    return v


_CONVERTERS = {
    "mode": _to_str,
    "num_components_expected": _to_int,
    "frequency": _to_float,
    "wait_policy": _to_str,
    "ros_mapping_whitelist": _to_str,
    "ros_mapping_blacklist": _to_str,
    "lock_memory": _to_bool,
    "safe_heap_size_kB": _to_int,
    "safe_stack_size_kB": _to_int,
    "cpu_affinity_mask": _to_int,
    "priority": _to_int,
    "use_sim_time": _to_bool,
    "ros_qos_depth": _to_int,
    "ros_qos_reliability": _to_str,
    "ros_qos_durability": _to_str,
    "ros_qos_deadline": _to_bool,
    "iteration_info": _to_bool,
    "action_max_goal_bytes": _to_int,
    "controller_manager": _to_str,
    "max_consecutive_overruns": _to_int,
    "max_overruns_per_second": _to_int,
    "max_let_overruns": _to_int,
    "hook_timeout": _to_float,
    "heartbeat_timeout": _to_float,
    "lanes": lambda v: _lanes_text(v),
    "lock": _to_str,
    "allowed_modules": lambda v: _regex_list(v),
    "robot_description": _to_str,
    "robot_description_file": _to_str,
    "hardware_components_initial_state.unconfigured": lambda v: _names(v),
    "hardware_components_initial_state.inactive": lambda v: _names(v),
}
# parameters whose field has another name (ros2_control's dotted ones)
_FIELDS = {
    "hardware_components_initial_state.unconfigured": "hardware_initial_unconfigured",
    "hardware_components_initial_state.inactive": "hardware_initial_inactive",
}
_EXPECTED = {
    "mode": "a string",
    "num_components_expected": "an integer",
    "frequency": "a number",
    "wait_policy": "a string",
    "ros_mapping_whitelist": "a string (a regular expression)",
    "ros_mapping_blacklist": "a string (a regular expression)",
    "lock_memory": "true or false",
    "safe_heap_size_kB": "an integer",
    "safe_stack_size_kB": "an integer",
    "cpu_affinity_mask": "an integer bit mask",
    "priority": "an integer",
    "use_sim_time": "true or false",
    "ros_qos_depth": "an integer",
    "ros_qos_reliability": "reliable or best_effort",
    "ros_qos_durability": "volatile or transient_local",
    "ros_qos_deadline": "true or false",
    "iteration_info": "true or false",
    "action_max_goal_bytes": "an integer",
    "controller_manager": "a node name, or '' for none",
    "max_consecutive_overruns": "an integer",
    "max_overruns_per_second": "an integer",
    "max_let_overruns": "an integer",
    "hook_timeout": "a number of seconds",
    "heartbeat_timeout": "a number of seconds",
    "lanes": "'name:cpu[:priority], ...' or a mapping of lane names to {cpu, priority}",
    "lock": "none, structure or all",
    "allowed_modules": "a list of regular expressions (or one string of them split at "
                       "whitespace)",
    "robot_description": "a string (the URDF)",
    "robot_description_file": "a string (the URDF's path)",
    "hardware_components_initial_state.unconfigured": "a list of hardware names",
    "hardware_components_initial_state.inactive": "a list of hardware names",
}
# one line each, for rt_runner --help (docs/runner.md has the whole story)
_MEANING = {
    "mode": "no_wait, wait_for_components or wait_for_trigger: when the loop starts",
    "num_components_expected": "the components wait_for_components waits for",
    "frequency": "the loop's rate [Hz]",
    "wait_policy": "absolute (stay on the grid after an overrun) or relative (re-anchor)",
    "ros_mapping_whitelist": "full-match regex: ports whose topics map to ROS topics",
    "ros_mapping_blacklist": "full-match regex: ports not mapped even if whitelisted",
    "lock_memory": "mlockall the worker",
    "safe_heap_size_kB": "heap pre-faulted before the loop starts",
    "safe_stack_size_kB": "stack pre-faulted before the loop starts",
    "cpu_affinity_mask": "the CPUs of the loop, a bit mask (2: CPU 1; 0: unchanged)",
    "priority": "the loop's SCHED_FIFO priority, 1 to 99",
    "use_sim_time": "follow /clock (the loop waits for it)",
    "ros_qos_depth": "QoS depth of the mapped topics",
    "ros_qos_reliability": "reliable or best_effort",
    "ros_qos_durability": "volatile or transient_local",
    "ros_qos_deadline": "ROS 2 inputs with a deadline request it as QoS deadline and lease",
    "iteration_info": "publish ~/iteration_info, one message per iteration",
    "action_max_goal_bytes": "largest goal (CDR bytes) a mapped action takes",
    "controller_manager": "ROS 2: where list_controllers/switch_controller are served",
    "max_consecutive_overruns": "watchdog: overruns in a row that end the loop (0: off)",
    "max_overruns_per_second": "watchdog: overruns within a second that end it (0: off)",
    "max_let_overruns": "watchdog: windows a LET lane may miss in a run (0: off)",
    "hook_timeout": "seconds a configure/start/stop/cleanup/safe_stop hook may take",
    "heartbeat_timeout": "seconds the loop runs on without its supervisor (0: off)",
    "lanes": "where lanes run: 'name:cpu[:priority], ...'",
    "lock": "none, structure (no load, unload, lifecycle once running) or all (tunables "
            "too)",
    "allowed_modules": "regexes a loaded component's module must match (empty: any)",
    "robot_description": "the robot's URDF, whose <ros2_control> hardware the loop runs",
    "robot_description_file": "the path of that URDF (when robot_description is empty)",
    "hardware_components_initial_state.unconfigured": "hardware left unconfigured at start",
    "hardware_components_initial_state.inactive": "hardware left inactive at start",
}


def parameter_help() -> list[tuple[str, str, str]]:
    """(name, default, meaning) of every runner parameter, in the order above."""
    fields = RunnerSettings.__dataclass_fields__
    out = []
    for name in _CONVERTERS:
        default = fields[_FIELDS.get(name, name)].default
        shown = "" if default in ("", None, ()) else (
            str(default).lower() if isinstance(default, bool) else str(default))
        out.append((name, shown, _MEANING[name]))
    return out


# parameters a runner node may carry that are not settings
_IGNORED: set[str] = set()


def set_initial_states(settings: RunnerSettings, params: Mapping[str, Any]) -> None:
    """``hardware_components_initial_state.*`` of a controller manager's parameters
    (its YAML section) onto ``settings``."""
    for key, value in _flat_initial_state(params).items():
        if key in _FIELDS:
            try:
                setattr(settings, _FIELDS[key], _names(value))
            except ValueError:
                raise ConfigurationError(
                    f"parameter {key!r} has value {value!r}, which is not "
                    f"{_EXPECTED[key]}") from None


def _names(v: Any) -> tuple[str, ...]:
    """A list of names (or one string of them split at whitespace or commas)."""
    if isinstance(v, str):
        return tuple(v.replace(",", " ").split())
    if isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v):
        return tuple(x for x in v if x)
    raise ValueError(v)


def _flat_initial_state(params: Mapping[str, Any]) -> Mapping[str, Any]:
    """``hardware_components_initial_state`` given as a mapping (a YAML's nesting)
    read as its dotted parameters."""
    nested = params.get("hardware_components_initial_state")
    if not isinstance(nested, Mapping):
        return params
    flat = {k: v for k, v in params.items() if k != "hardware_components_initial_state"}
    for key, value in nested.items():
        flat[f"hardware_components_initial_state.{key}"] = value
    return flat


def _regex_list(v: Any) -> tuple[str, ...]:
    """``allowed_modules``: a list of strings, or one string split at whitespace."""
    if isinstance(v, str):
        return tuple(v.split())
    if isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v):
        return tuple(x for x in v if x)
    raise ValueError(v)


def _lanes_text(v: Any) -> str:
    """The ``lanes`` parameter as its text form (a mapping from YAML is accepted)."""
    if isinstance(v, Mapping):
        parts = []
        for name, where in v.items():
            if isinstance(where, Mapping):
                cpu, prio = where.get("cpu"), where.get("priority")
            else:
                cpu, prio = where, None
            text = f"{name}:{'' if cpu is None else cpu}"
            parts.append(text + ("" if prio is None else f":{prio}"))
        return ", ".join(parts)
    if not isinstance(v, str):
        raise TypeError(v)
    return v


def parse_lanes(text: str) -> dict[str, tuple[int | None, int | None]]:
    """``"name:cpu[:priority], ..."`` as lane -> (cpu or None, priority or None)."""
    out: dict[str, tuple[int | None, int | None]] = {}
    for part in text.replace(";", ",").split(","):
        part = part.strip()
        if not part:
            continue
        fields = [f.strip() for f in part.split(":")]
        if len(fields) > 3 or not fields[0]:
            raise ValueError(f"{part!r} is not name:cpu[:priority]")
        try:
            cpu = int(fields[1]) if len(fields) > 1 and fields[1] else None
            prio = int(fields[2]) if len(fields) > 2 and fields[2] else None
        except ValueError:
            raise ValueError(f"{part!r}: the CPU and the priority are integers") from None
        if cpu is not None and cpu < 0:
            raise ValueError(f"{part!r}: a CPU is a number from 0")
        if prio is not None and not 1 <= prio <= 99:
            raise ValueError(f"{part!r}: priority {prio} is out of range; SCHED_FIFO takes 1 to 99")
        out[fields[0]] = (cpu, prio)
    return out


def lane_placement(
    settings: RunnerSettings, lanes: list[str], allowed: list[int]
) -> dict[str, tuple[int, int, str]]:
    """Where each lane other than main runs: (CPU mask, priority, how it was chosen).

    A lane named in ``settings.lanes`` gets its CPU and priority; the others get, in
    order, a CPU of their own among ``allowed`` that neither the main lane (its
    ``cpu_affinity_mask``) nor another lane has, from the highest down, and the
    runner's priority; where none is left, the lane is not pinned (it says so).
    """
    given = parse_lanes(settings.lanes)
    mask = settings.cpu_affinity_mask
    taken = {c for c in allowed if mask >> c & 1}
    taken |= {cpu for cpu, _ in given.values() if cpu is not None}
    free = [c for c in sorted(allowed, reverse=True) if c not in taken]
    out: dict[str, tuple[int, int, str]] = {}
    for lane in lanes:
        cpu, prio = given.get(lane, (None, None))
        priority = prio if prio is not None else settings.priority
        if cpu is not None:
            out[lane] = (1 << cpu, priority, f"CPU {cpu} (the lanes parameter)")
        elif free:
            cpu = free.pop(0)
            out[lane] = (1 << cpu, priority, f"CPU {cpu} (a CPU of its own)")
        else:
            out[lane] = (0, priority, "not pinned (no CPU left of its own)")
    return out
