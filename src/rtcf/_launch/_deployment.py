"""From a launch description to what runs: runners and the components they load.

A ``<node pkg="rtcf" type="rt_runner">`` (ROS 2: ``exec="rt_runner"``) is a runner;
its private parameters are its settings. A ``<node pkg="rtcf" type="rt_launcher"
args="MODULE ClassName [-f|--is_first]">`` loads one component into a runner: the
node's name, namespace and remaps become the component's, and its private
parameters its parameters (``is_first``, ``topics_ignore_for_graph``, ``rt_package``,
``rt_type`` and ``runner`` are read by the launcher itself).

ros2_control's nodes stand for the same: ``<node pkg="controller_manager"
exec="ros2_control_node">`` is a runner that is its own controller manager (of its
parameters, only ``update_rate`` and the runner's settings are read; the rest is the
YAML's controller manager section; its ports' topics are all mapped, as ros2_control's
controllers' topics are ROS 2 topics), and a ``spawner`` loads its controllers into
the runner of its controller manager (:mod:`._spawner`). Every other node is kept as it is
(``other_nodes``): ``rtcf launch`` starts it as ros2 launch would (:mod:`rtcf._cli._other_nodes`).

Each runner gets the robot description it would read, with its ``<ros2_control>``
hardware parsed (:mod:`._robot_descriptions`): ``runner.robot_description`` (the text)
and ``runner.hardware``; ``deployment.robot_description`` and ``deployment.hardware``
are the one runner's.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field

from .._core._booleans import parse_bool
from .._core._errors import ConfigurationError, LaunchError, Location
from .._core._faults import FailurePolicy
from .._core._lane_names import lane_from_params
from .._core._names import expand, join, namespace_of, normalize_namespace
from .._core._params import ParameterStore
from .._core._rates import Rate
from .._core._robot_description import HardwareInfo
from .._core._runner import ComponentSpec
from .._core._settings import RunnerSettings, set_initial_states
from ._controller_setup import ControllerSetup, read_setup
from ._description import LaunchDescription, NodeDescription
from ._robot_descriptions import PARAM as DESCRIPTION_PARAM
from ._robot_descriptions import RobotDescription, for_runner
from ._spawner import controller_specs, is_spawner, parse

PACKAGE = "rtcf"
RUNNER = "rt_runner"
LAUNCHER = "rt_launcher"
CONTROL_PACKAGE, CONTROL_NODE = "controller_manager", "ros2_control_node"
# a ros2_control_node read as a runner: ros2_control's default update_rate, and every
# port's topic on ROS 2 (with hardware, the interfaces are no ports: what is left are
# the controllers' topics, ~/commands, /joint_states, ~/odom, /tf, ...)
CONTROL_NODE_RATE = 100.0
CONTROL_NODE_WHITELIST = ".*"
RUNNER_SETTINGS = frozenset(RunnerSettings.__dataclass_fields__) - {"notes"}
LAUNCHER_PARAMS = (
    "is_first",
    "is_sync",
    "topics_ignore_for_graph",
    "rt_package",
    "rt_type",
    "runner",
    "on_error",
    "max_restarts",
    "fallback",
    "on_deadline",
    "deadline",
    "rate",
    "every",
    "phase",
    "cost_us",
    "lane",
)


@dataclass
class RunnerDeployment:
    name: str  # full name of the runner node
    settings: RunnerSettings
    location: Location
    components: list[ComponentSpec] = field(default_factory=list)
    # what the launch file sets in the runner node's environment (<env>), e.g.
    # ROSCONSOLE_CONFIG_FILE; roslaunch would start the runner's process with it
    env: dict[str, str] = field(default_factory=dict)
    # its controller manager's section of the <param from=...> files (update_rate, the
    # controllers' types and parameters), if it was given any
    controllers: ControllerSetup | None = None
    # the robot description it reads (its text, where it came from, its hardware)
    description: RobotDescription | None = None

    @property
    def robot_description(self) -> str | None:
        """The robot description's text (xacro already run), or None."""
        return None if self.description is None else self.description.text

    @property
    def hardware(self) -> list[HardwareInfo]:
        """One HardwareInfo per ``<ros2_control>`` tag of the robot description."""
        return [] if self.description is None else list(self.description.hardware)


@dataclass
class Deployment:
    source: str
    runners: list[RunnerDeployment]
    parameters: ParameterStore
    other_nodes: list[NodeDescription] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what was found, for the user

    @property
    def robot_description(self) -> str | None:
        """The one runner's robot description (None without runners or description)."""
        return self.runner.robot_description if self.runners else None

    @property
    def hardware(self) -> list[HardwareInfo]:
        """The one runner's hardware, from its robot description's ``<ros2_control>`` tags."""
        return self.runner.hardware if self.runners else []

    @property
    def runner(self) -> RunnerDeployment:
        """The one runner (an error if the file defines none or several)."""
        if len(self.runners) != 1:
            names = ", ".join(r.name for r in self.runners)
            raise LaunchError(
                f"defines {len(self.runners)} runners ({names}); this command runs one: "
                "split the file, or start each runner on its own",
                file=self.source,
            )
        return self.runners[0]


def is_runner(node: NodeDescription) -> bool:
    return node.package == PACKAGE and node.executable == RUNNER


def is_ros2_control_node(node: NodeDescription) -> bool:
    """ros2_control's controller manager: a runner given its YAML, as rt_runner would be."""
    return node.package == CONTROL_PACKAGE and node.executable == CONTROL_NODE


def is_launcher(node: NodeDescription) -> bool:
    return node.package == PACKAGE and node.executable == LAUNCHER


def plan(description: LaunchDescription) -> Deployment:
    """Pick runners and launchers out of ``description`` and check what can be checked
    without importing anything."""
    params = description.parameters
    warnings = list(description.warnings)
    runners: list[RunnerDeployment] = []
    launchers: list[NodeDescription] = []
    spawners: list[NodeDescription] = []
    others: list[NodeDescription] = []
    for node in description.nodes:
        if is_runner(node) or is_ros2_control_node(node):
            runners.append(_runner(node, params, warnings))
            runner = runners[-1]
            runner.description = for_runner(node, description, warnings)
            if runner.description is not None and not runner.settings.robot_description:
                # the loop's hardware (built in the worker from the settings)
                runner.settings.robot_description = runner.description.text
        elif is_launcher(node):
            launchers.append(node)
        elif is_spawner(node):
            spawners.append(node)
        else:
            others.append(node)  # rtcf launch starts them (rtcf._cli._other_nodes)
    if (launchers or spawners) and not runners:
        first = (launchers or spawners)[0].location
        raise LaunchError(
            "the file loads components but defines no runner; add "
            '<node pkg="rtcf" type="rt_runner" name="rt_runner"/> with its parameters',
            file=first.file,
            line=first.line,
        )
    by_name = {r.name: r for r in runners}
    for node in launchers:
        spec, runner_name = _component_spec(node, params)
        target = _pick_runner(node, runner_name, runners, by_name)
        target.components.append(spec)
    for node in spawners:
        _spawn(node, runners, warnings)
    notes = [f"runner {r.name}: {r.description.summary()}" for r in runners if r.description]
    return Deployment(description.source, runners, params, others, warnings, notes)


def _runner(node: NodeDescription, params: ParameterStore,
            warnings: list[str]) -> RunnerDeployment:
    private = params.get(node.full_name, {})
    private = {k: v for k, v in (private if isinstance(private, dict) else {}).items()
               if k != DESCRIPTION_PARAM}  # the robot description's, not a setting
    where = f"{node.executable} {node.full_name!r}"
    control_node = is_ros2_control_node(node)
    update_rate = private.get("update_rate") if control_node else None
    if control_node:
        # its parameters are the controller manager's (update_rate, the types): of those
        # only the runner's own settings are read; it is the controller manager itself,
        # and its controllers' topics are ROS 2 topics, as ros2_control's are
        private = {"mode": "no_wait", "controller_manager": node.name,
                   "ros_mapping_whitelist": CONTROL_NODE_WHITELIST,
                   **{k: v for k, v in private.items() if k in RUNNER_SETTINGS
                      or k.startswith("hardware_components_initial_state")}}
    try:
        settings = RunnerSettings.from_params(private, where=where)
        controllers = None
        if node.params_files and settings.controller_manager:
            manager = expand(settings.controller_manager, node.namespace)
            controllers = read_setup(node.params_files, manager)
            set_initial_states(settings, controllers.params_for(manager))
            controllers.set_frequency(settings, "frequency" in private, where)
        if control_node:
            _control_node_rate(settings, update_rate, "frequency" in private, where)
    except LaunchError:
        raise
    except Exception as exc:  # ConfigurationError: add the file and line
        raise LaunchError(str(exc), file=node.location.file, line=node.location.line) from None
    warnings.extend(f"{node.location}: {n}" for n in settings.notes)
    return RunnerDeployment(node.full_name, settings, node.location, env=dict(node.env),
                            controllers=controllers)


def _control_node_rate(settings: RunnerSettings, rate: object, given: bool,
                       where: str) -> None:
    """A ros2_control_node's loop runs at its ``update_rate`` parameter, as the node
    reads it (its ``<param>``s and its files' section, in the file's order), else at
    ros2_control's default, 100 Hz; a ``frequency`` of its own must agree."""
    if rate is None:
        if given:
            return
        rate = CONTROL_NODE_RATE
        note = f"update_rate not given, using ros2_control's default {CONTROL_NODE_RATE:g} Hz"
    else:
        note = ""
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0:
        raise ConfigurationError(f"{where}: update_rate {rate!r} is not a positive number of Hz")
    if given:
        if settings.frequency != rate:
            raise ConfigurationError(
                f"{where}: frequency {settings.frequency:g} Hz and update_rate {rate:g} Hz "
                "differ; give one of them, or the same value")
        return
    settings.frequency = float(rate)
    settings.notes = [n for n in settings.notes if "no frequency given" not in n]
    if note:
        settings.notes.append(f"{where}: {note}")
    settings.validate(f"{where} (update_rate)")


def _spawn(node: NodeDescription, runners: list[RunnerDeployment], warnings: list[str]) -> None:
    """A ros2_control spawner's controllers, added to the runner of its controller manager."""
    request = parse(node)
    managers = {_manager_of(r): r for r in runners if r.settings.controller_manager}
    target = managers.get(request.manager)
    if target is None:
        raise LaunchError(
            f"spawner {node.full_name!r}: controller manager {request.manager} is no runner's "
            f"(theirs: {', '.join(managers) or 'none'}); "
            "set -c, or the runner's controller_manager",
            file=node.location.file, line=node.location.line)
    for option in request.ignored:
        warnings.append(f"{node.location}: spawner {node.full_name!r}: {option} ignored: "
                        "the runner loads and starts its controllers at once, unloads at exit")
    target.components.extend(controller_specs(node, request, target.controllers))


def _manager_of(runner: RunnerDeployment) -> str:
    if runner.controllers is not None:
        return runner.controllers.manager
    return expand(runner.settings.controller_manager, namespace_of(runner.name))


def _component_spec(node: NodeDescription, params: ParameterStore) -> tuple[ComponentSpec, str]:
    loc = node.location

    def err(msg: str) -> LaunchError:
        return LaunchError(f"rt_launcher {node.full_name!r}: {msg}", file=loc.file, line=loc.line)

    private = params.get(node.full_name, {})
    private = private if isinstance(private, dict) else {}
    try:
        words = shlex.split(node.args)
    except ValueError as exc:
        raise err(f"args {node.args!r} cannot be split: {exc}") from None
    flags = [w for w in words if w.startswith("-")]
    positional = [w for w in words if not w.startswith("-")]
    is_first_flag = False
    for flag in flags:
        if flag in ("-f", "--is_first"):
            is_first_flag = True
        elif flag in ("-s", "--is_sync"):
            pass  # accepted for compatibility: every component runs synchronously here
        else:
            raise err(f"unknown option {flag!r} in args; allowed: -f/--is_first")
    if len(positional) > 2:
        raise err(f'args {node.args!r} has too many words; use "MODULE ClassName [-f]"')
    module = positional[0] if len(positional) == 2 else ""
    class_name = positional[-1] if positional else ""
    for key, current in (("rt_package", module), ("rt_type", class_name)):
        if key in private:
            if current:
                raise err(f"{key} is given both in args and as parameter ~{key}; keep one")
            if not isinstance(private[key], str):
                raise err(f"parameter ~{key} must be a string")
            if key == "rt_package":
                module = private[key]
            else:
                class_name = private[key]
    if not class_name:
        raise err('no component class given; use args="MODULE ClassName" or parameter ~rt_type')
    if not module:
        if "." in class_name:
            module, _, class_name = class_name.rpartition(".")
        else:
            raise err(
                f'no module given for class {class_name!r}; use args="MODULE {class_name}" '
                "or parameter ~rt_package"
            )
    is_first = is_first_flag
    try:  # the one boolean parser: an error names the parameter
        value = parse_bool(private.get("is_first", False), "~is_first")
        autostart = parse_bool(private.get("autostart", True), "~autostart")
    except ConfigurationError as exc:
        raise err(exc.message) from None
    if "is_first" in private:
        if is_first_flag and not value:
            raise err("conflicting is_first: args has -f but parameter ~is_first is false")
        is_first = is_first or value
    ignore = private.get("topics_ignore_for_graph", "")
    if not isinstance(ignore, str):
        raise err(f"parameter ~topics_ignore_for_graph is {ignore!r}; it must be a regex string")
    runner_name = private.get("runner", "")
    try:
        policy = FailurePolicy.from_params(private, node.full_name)
        rate = Rate.from_params(private, node.full_name)
        lane = lane_from_params(private, node.full_name)
    except ConfigurationError as exc:
        raise err(exc.message) from None
    spec = ComponentSpec(
        name=node.name,
        module=module,
        class_name=class_name,
        namespace=node.namespace,
        remaps=list(node.remaps),
        is_first=is_first,
        topics_ignore_for_graph=ignore,
        location=loc,
        policy=policy,
        rate=rate,
        lane=lane,
        autostart=autostart,
    )
    return spec, str(runner_name)


def _pick_runner(
    node: NodeDescription,
    wanted: str,
    runners: list[RunnerDeployment],
    by_name: dict[str, RunnerDeployment],
) -> RunnerDeployment:
    loc = node.location
    if wanted:
        full = (
            normalize_namespace(wanted) if wanted.startswith("/") else join(node.namespace, wanted)
        )
        for candidate in (full, normalize_namespace(wanted)):
            if candidate in by_name:
                return by_name[candidate]
        raise LaunchError(
            f"rt_launcher {node.full_name!r}: parameter ~runner names {wanted!r}, but the runners "
            f"are {', '.join(by_name) or 'none'}",
            file=loc.file,
            line=loc.line,
        )
    if len(runners) > 1:
        raise LaunchError(
            f"rt_launcher {node.full_name!r}: the file has {len(runners)} runners; say which one "
            'loads this component with <param name="runner" value="..."/>',
            file=loc.file,
            line=loc.line,
        )
    return runners[0]
