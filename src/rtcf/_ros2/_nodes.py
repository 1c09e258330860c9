"""``rt_runner`` and ``rt_launcher`` as ROS 2 executables (what ``ros2 run`` would start).

``rt_runner --ros-args -r __node:=NAME -r __ns:=/NS -p frequency:=1000.0 ...`` is a
ROS 2 node whose parameters are the runner's settings. It serves, under its own
name (so several runners share a graph):

* ``~/load_component`` and ``~/unload_component``, typed
  ``rcl_interfaces/srv/SetParametersAtomically``: a request is a list of
  parameters (``module``, ``class``, ``name``, ``namespace``, ``remaps`` as
  ``from:=to`` strings, ``is_first``, ``topics_ignore_for_graph``, ``launcher``,
  and ``param.<name>`` for each component parameter); the answer says
  ``successful`` and, when refused, the ``reason``. Standard types, so no
  interface package has to be built.
* ``~/activate_rt_loop`` and ``~/deactivate_rt_loop`` (``std_srvs/srv/Trigger``)
  for mode ``wait_for_trigger``.
* ``~/tune_component`` and ``~/lifecycle_component`` (``SetParametersAtomically``):
  what a launcher's node forwards, a tunable value or a log level, and a lifecycle
  transition (``name``, ``transition``; without a transition, the state), answered
  with JSON in ``reason``.

``rt_launcher MODULE CLASS [-f] --ros-args -r __node:=NAME -r from:=to -p k:=v``
asks its runner (parameter ``runner``, default ``/rt_runner``) to load the class as
a component named like the launcher node, stays alive, and asks for the unload
when it is stopped. Its node is the component's face: parameters, logger levels and
the lifecycle services, forwarded to the runner. The runner unloads the components
of launchers that vanish (killed with SIGKILL); a launcher whose runner vanishes
exits with a message.
"""

from __future__ import annotations

import dataclasses
import json
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

from .._core._booleans import parse_bool
from .._core._errors import RtcfError
from .._core._executor import ABORT, STOP
from .._core._faults import FailurePolicy
from .._core._lane_names import lane_from_params
from .._core._lifecycle import STATE_IDS, TransitionOutcome
from .._core._names import expand
from .._core._rates import Rate
from .._core._runner import ComponentSpec
from .._core._settings import RunnerSettings
from .._launch._controller_setup import read_setup
from .._runtime._request_fields import RequestRefused, check_request
from .._runtime._requests import Request, RequestQueue, serve_request, stop_on_signals
from .._runtime._usage import help_printed, launcher_usage, runner_usage
from ._face import ComponentFace, ros_logger_name
from ._robot_description import PARAM as DESCRIPTION_PARAM
from ._robot_description import DescriptionListener

WATCH_EVERY_S = 1.0
ANSWER_TIMEOUT_S = 60.0  # the longest a launcher waits for its runner's answer
# the launcher's own, never a component's (rclpy's nodes declare the first two)
_RESERVED = {"use_sim_time", "start_type_description_service", "runner", "is_first",
             "topics_ignore_for_graph", "autostart"}


def _say(who: str, text: str) -> None:
    print(f"{who}: {text}", file=sys.stderr, flush=True)


def _node(default_name: str, argv: list[str], *, logger_service: bool = True) -> tuple[Any, Any]:
    import rclpy
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    rclpy.init(args=argv, context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = Node(
        default_name,
        context=context,
        automatically_declare_parameters_from_overrides=True,
        enable_logger_service=logger_service,
    )
    return rclpy, node


def _params(node: Any) -> dict[str, Any]:
    return {name: p.value for name, p in node._parameters.items()}


# the --ros-args options that take a value (rcl's arguments.h)
_VALUED = ("-r", "--remap", "-p", "--param", "--params-file", "--log-level", "-e",
           "--enclave", "--log-config-file")


def _ros_args(argv: list[str]) -> Iterator[tuple[str, str]]:
    """``(option, value)`` of each valued option inside --ros-args, in order."""
    inside = False
    it = iter(argv)
    for arg in it:
        if arg == "--ros-args":
            inside = True
        elif arg == "--":
            inside = False
        elif inside and arg in _VALUED:
            yield arg, next(it, "")


def params_files(argv: list[str]) -> list[str]:
    """The ``--params-file PATH`` of --ros-args (<param from=...> in a launch file)."""
    return [path for option, path in _ros_args(argv) if option == "--params-file" and path]


def _ros_remaps(argv: list[str], node: str = "") -> list[tuple[str, str]]:
    """The ``-r from:=to`` rules of --ros-args, without the special __node/__ns ones, and
    the ``-r NODE:from:=to`` ones whose NODE is ``node`` (the node's name)."""
    out: list[tuple[str, str]] = []
    for option, rule in _ros_args(argv):
        if option in ("-r", "--remap"):
            src, _, dst = rule.partition(":=")
            who, colon, rest = src.partition(":")
            if colon and who == node and "//" not in rest:  # a rule for this node only
                src = rest
            if src and dst and not src.startswith("__") and ":" not in src:
                out.append((src, dst))
    return out


def args_log_level(logger: str) -> int | None:
    """What ``--ros-args --log-level NAME:=LEVEL`` gave ``logger`` (or the nearest of its
    ancestors: 'arm' covers 'arm.sum1') in this process; None if it gave none."""
    import rclpy.logging

    parts = [p for p in logger.split(".") if p]
    for n in range(len(parts), 0, -1):
        level = int(rclpy.logging.get_logger_level(".".join(parts[:n])))
        if level:  # 0: UNSET
            return level
    return None


# -- the runner ------------------------------------------------------------------------


def runner_main(argv: list[str] | None = None) -> int:
    from rcl_interfaces.msg import SetParametersResult
    from rcl_interfaces.srv import SetParametersAtomically
    from std_srvs.srv import Trigger

    from .._runtime._supervisor import WorkerRunner
    from ._bridge import Ros2Bridge

    argv = list(sys.argv if argv is None else argv)
    if help_printed(argv, runner_usage, "ros2"):
        return 0
    rclpy, node = _node("rt_runner", argv)
    name = node.get_fully_qualified_name()
    try:
        params = _params(node)
        # its robot description: this parameter (Humble's way), else the topic (Jazzy's)
        description = DescriptionListener(
            node, lambda text: _say(name, text), params.pop(DESCRIPTION_PARAM, None))
        settings = RunnerSettings.from_params(params, where=f"rt_runner {name}")
        # --params-file controllers.yaml (<param from=...>): its controller manager section
        controllers = None
        files = params_files(argv)
        if files and settings.controller_manager:
            manager = expand(settings.controller_manager, node.get_namespace())
            controllers = read_setup(files, manager)
            controllers.set_frequency(settings, "frequency" in _params(node), f"rt_runner {name}")
    except RtcfError as exc:
        _say("rt_runner", f"error: {exc}")
        return 1
    bridge = Ros2Bridge(node=node)
    runner = WorkerRunner(settings, name=name, bridge=bridge)
    runner.controller_setup = controllers
    requests = RequestQueue(runner)
    submit = requests.submit
    launchers: dict[str, str] = {}  # component -> launcher node that asked for it

    admitted = {"load_component": "loads", "unload_component": "unloads",
                "lifecycle_component": "lifecycle transitions", "tune_component": "tunables"}

    def answered(response: Any, ok: bool, reason: str = "") -> Any:
        response.result = SetParametersResult(successful=ok, reason=reason)
        return response

    def fields(service: str, request: Any, response: Any) -> dict[str, Any] | None:
        """The request's fields, type-checked, and the request admitted by the runner's
        lock and allowed_modules; None (and the refusal in ``response``) if not. Nothing
        is imported or made before, and the loop is not stopped for a refusal."""
        try:
            values = check_request(
                service, {p.name: _value(p.value) for p in request.parameters})
            what = admitted[service]
            if what != "tunables" or any(k.startswith("param.") for k in values):
                runner.admits(what, values.get("module") if what == "loads" else None,
                              values.get("name") if what == "unloads" else None)
            return values
        except RequestRefused as exc:
            answered(response, False, str(exc))
            return None

    def on_load(request: Any, response: Any) -> Any:
        values = fields("load_component", request, response)
        if values is None:
            return response
        try:  # what can be refused without the worker, is (the loop goes on meanwhile)
            spec, _ = _spec(values)
            runner.admits("loads", spec.module, spec.full_name, spec.class_name)
        except RtcfError as exc:
            return answered(response, False, str(exc))
        req = submit("load", values)
        # on success the reason carries the component as the launcher shows it (JSON)
        return answered(response, req.ok, req.reason)

    def on_tune(request: Any, response: Any) -> Any:
        # from the bridge thread: WorkerRunner validates and queues under its own lock
        values = fields("tune_component", request, response)
        if values is None:
            return response
        try:
            component = str(values.pop("name", ""))
            for key, value in values.items():
                if key == "log_level":
                    runner.set_log_level(component, int(value))
                elif key.startswith("param."):
                    runner.set_parameter(component, key[len("param.") :], value)
                else:
                    raise RtcfError(f"a tune request has no parameter {key!r}")
            return answered(response, True)
        except RtcfError as exc:
            return answered(response, False, str(exc))

    def on_lifecycle(request: Any, response: Any) -> Any:
        # from the bridge thread: waits for the loop's next iteration, which goes on
        values = fields("lifecycle_component", request, response)
        if values is None:
            response.result.reason = json.dumps({"error": response.result.reason})
            return response
        component = str(values.get("name", ""))
        transition = values.get("transition")
        answer: dict[str, Any] = {}
        ok = True
        try:
            if transition not in (None, ""):
                outcome = runner.change_state(component, transition)
                answer["outcome"] = dataclasses.asdict(outcome)
                ok = outcome.ok
            answer["state"] = runner.lifecycle_state(component)
        except RtcfError as exc:
            ok = False
            answer["error"] = str(exc)
        return answered(response, ok, json.dumps(answer))

    def on_unload(request: Any, response: Any) -> Any:
        values = fields("unload_component", request, response)
        if values is None:
            return response
        req = submit("unload", str(values.get("name", "")))
        return answered(response, req.ok, req.reason)

    def trigger(kind: str) -> Callable[[Any, Any], Any]:
        def on_trigger(request: Any, response: Any) -> Any:
            req = submit(kind, None)
            response.success, response.message = req.ok, req.reason
            return response

        return on_trigger

    node.create_service(SetParametersAtomically, "~/load_component", on_load)
    node.create_service(SetParametersAtomically, "~/unload_component", on_unload)
    node.create_service(SetParametersAtomically, "~/tune_component", on_tune)
    node.create_service(SetParametersAtomically, "~/lifecycle_component", on_lifecycle)
    node.create_service(Trigger, "~/activate_rt_loop", trigger("activate"))
    node.create_service(Trigger, "~/deactivate_rt_loop", trigger("deactivate"))

    presence = _Presence()

    def watch() -> None:  # a launcher killed with SIGKILL never asks for its unload
        presence.update(node)
        for component, launcher in list(launchers.items()):
            if launcher and presence.gone(launcher):
                launchers.pop(component, None)
                requests.put("unload", component)

    node.create_timer(WATCH_EVERY_S, watch)

    # a signal's STOP, kept past clear_stop: the components' safe_stop hooks run
    stop_asked = stop_on_signals(lambda: runner.request_stop(abort=True))

    def load(payload: Any) -> str:
        # a launcher's request (its fields), or a controller's spec (load_controller)
        spec, launcher = (payload, "") if isinstance(payload, ComponentSpec) else _spec(payload)
        if spec.log_level is None:  # the launcher gave none: this runner's --log-level
            spec.log_level = args_log_level(ros_logger_name(spec.full_name))
        runner.load(spec, launcher=launcher)
        launchers[spec.full_name] = launcher
        if launcher:  # it called us, so it exists even if the graph lags behind
            presence.seen.add(launcher)
        _say(name, f"loaded {spec.full_name} ({spec.module}.{spec.class_name})"
                   f"{runner.lanes.said(spec.full_name)}")
        return json.dumps(runner.components[spec.full_name])

    def unloaded(full: str) -> str:
        launchers.pop(full, None)
        return ""

    def serve(req: Request) -> None:
        serve_request(req, runner, lambda text: _say(name, text), load, unloaded)

    status = 0
    try:
        # a description being published comes before the worker starts, which builds its
        # hardware; a bringup with a controllers file waits for one
        description.settle(expected=controllers is not None)
        if description.robot_description and not settings.robot_description:
            settings.robot_description = description.robot_description
        runner.start()
        _say(name, f"ready: {settings.frequency:g} Hz, mode {settings.mode}")

        def run() -> None:
            result = runner.run(None)
            if runner.stop_reason in (STOP, ABORT):
                _say(name, f"stopped after {result.iterations} iterations")

        requests.serve_until_stopped(serve, stop_asked.is_set, run)
    except RtcfError as exc:
        _say(name, f"error: {exc}")
        status = 1
    finally:
        for err in runner.shutdown() if runner.process is not None else []:
            _say(name, f"error: {err}")
            status = 1
        runner.close()
        rclpy.try_shutdown(context=node.context)
    return status


def _value(v: Any) -> Any:
    """The Python value of an rcl_interfaces ParameterValue."""
    from rclpy.parameter import parameter_value_to_python

    return parameter_value_to_python(v)


def _spec(values: dict[str, Any]) -> tuple[ComponentSpec, str]:
    missing = [k for k in ("module", "class", "name") if not values.get(k)]
    if missing:
        raise RtcfError(
            "a load request needs the parameters module, class and name; missing: "
            + ", ".join(missing)
        )
    remaps = []
    for rule in values.get("remaps") or []:
        if rule == "":  # a launcher's empty list (ROS 2 parameters cannot carry one)
            continue
        src, sep, dst = str(rule).partition(":=")
        if not sep or not src or not dst:
            raise RtcfError(f"remap {rule!r} is not of the form from:=to")
        remaps.append((src, dst))
    # ROS 2 nests parameter names with '.', the tree rtcf keeps (as launch files do) '/'
    params = {
        k[len("param.") :].replace(".", "/"): v for k, v in values.items() if k.startswith("param.")
    }
    spec = ComponentSpec(
        name=str(values["name"]),
        module=str(values["module"]),
        class_name=str(values["class"]),
        namespace=str(values.get("namespace") or "/"),
        remaps=remaps,
        params=params,
        is_first=bool(values.get("is_first", False)),
        topics_ignore_for_graph=str(values.get("topics_ignore_for_graph") or ""),
        log_level=int(values["log_level"]) if values.get("log_level") else None,
        autostart=bool(values.get("autostart", True)),
    )
    spec.policy = FailurePolicy.from_params(params, spec.full_name)  # on_error, fallback
    spec.rate = Rate.from_params(params, spec.full_name)  # rate, every, phase, cost_us
    spec.lane = lane_from_params(params, spec.full_name)
    return spec, str(values.get("launcher") or "")


# -- the launcher ------------------------------------------------------------------------


def launcher_main(argv: list[str] | None = None) -> int:
    from rcl_interfaces.msg import Parameter
    from rcl_interfaces.srv import SetParametersAtomically
    from rclpy.parameter import Parameter as PyParameter
    from rclpy.utilities import remove_ros_args

    argv = list(sys.argv if argv is None else argv)
    if help_printed(argv, launcher_usage, "ros2"):
        return 0
    words = remove_ros_args(argv)[1:]
    is_first = any(w in ("-f", "--is_first") for w in words)
    positional = [w for w in words if not w.startswith("-")]
    # the component's logger services are its face's, which the runner's worker obeys
    rclpy, node = _node("rt_launcher", argv, logger_service=False)
    me = node.get_fully_qualified_name()
    params = _params(node)
    module = positional[0] if positional else str(params.get("rt_package") or "")
    class_name = positional[1] if len(positional) > 1 else str(params.get("rt_type") or "")
    if not module or not class_name:
        _say(f"rt_launcher {me}", "error: give MODULE CLASS (or the rt_package/rt_type params)")
        return 2
    runner = str(params.get("runner") or "/rt_runner")
    try:  # the one boolean parser (rtcf launch's too): an error names the parameter
        autostart = parse_bool(params.get("autostart", True), f"{me}'s autostart")
    except RtcfError as exc:
        _say(f"rt_launcher {me}", f"error: {exc}")
        return 2
    from rclpy.executors import MultiThreadedExecutor

    # two threads: a lifecycle service waits for the runner's answer, which the other takes
    executor = MultiThreadedExecutor(num_threads=2, context=node.context)
    executor.add_node(node)
    values: dict[str, Any] = {
        "module": module,
        "class": class_name,
        "name": node.get_name(),
        "namespace": node.get_namespace(),
        "remaps": [f"{a}:={b}" for a, b in _ros_remaps(argv, node.get_name())] or [""],
        "is_first": is_first or bool(params.get("is_first", False)),
        "topics_ignore_for_graph": str(params.get("topics_ignore_for_graph") or ""),
        "autostart": autostart,
        "launcher": me,
    }
    if values["remaps"] == [""]:
        values["remaps"] = []
    # --ros-args --log-level NAME:=LEVEL (the component's logger, or an ancestor of it):
    # its start level, before configure; ROS 2's ROSCONSOLE_CONFIG_FILE
    start_level = args_log_level(ros_logger_name(me))
    if start_level is not None:
        values["log_level"] = start_level
    for key, value in params.items():
        if key not in _RESERVED and key not in ("rt_package", "rt_type"):
            values[f"param.{key}"] = value

    presence = _Presence()

    def request(service: str, vals: dict[str, Any], wait_s: float = 30.0) -> tuple[bool, str]:
        client = node.create_client(SetParametersAtomically, f"{runner}/{service}")
        if not client.wait_for_service(timeout_sec=wait_s):
            return False, f"no runner answers at {runner}/{service}"
        req = SetParametersAtomically.Request()
        req.parameters = [
            Parameter(name=k, value=PyParameter(k, value=_plain(v)).get_parameter_value())
            for k, v in vals.items()
            if not (isinstance(v, list) and not v)
        ]
        future = client.call_async(req)
        # a load or unload runs the component's hooks, which may take long; a runner
        # that dies meanwhile (Ctrl-C to both, a crash) never answers: stop waiting
        # once it has left the graph
        deadline = time.monotonic() + ANSWER_TIMEOUT_S
        next_check = time.monotonic() + WATCH_EVERY_S
        presence.seen.add(runner)  # it offers the service, so it exists
        while not future.done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
            if time.monotonic() >= next_check:
                next_check += WATCH_EVERY_S
                presence.update(node)
                if presence.gone(runner):
                    return False, f"the runner {runner} is gone"
        if not future.done() or future.result() is None:
            return False, f"{runner}/{service} did not answer within {ANSWER_TIMEOUT_S:g} s"
        result = future.result().result
        return bool(result.successful), str(result.reason)

    who = f"rt_launcher {me}"
    # Ctrl-C or SIGTERM from here on ends the launcher through the unload below (a
    # component being loaded still is, and then unloaded); a second one at once
    stop = threading.Event()

    def handler(signum: int, frame: FrameType | None) -> None:
        if stop.is_set():
            _say(who, "interrupted again: exiting without unloading")
            raise SystemExit(130)
        stop.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    ok, reason = request("load_component", values)
    if not ok:
        _say(who, f"error: {runner} refused to load {module}.{class_name}: {reason}")
        node.destroy_node()
        rclpy.try_shutdown(context=node.context)
        return 1
    _say(who, f"loaded into {runner}")
    info = json.loads(reason)
    level = int(info.get("log_level") or 20)
    link = _RunnerLink(node, runner, who)
    face = ComponentFace(node, info, link, level, link)
    full = str(info["name"])
    status = 0
    last_check = 0.0
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.1)
        now = time.monotonic()
        if now - last_check >= WATCH_EVERY_S:
            last_check = now
            presence.update(node)
            if presence.gone(runner):
                _say(who, f"error: the runner {runner} is gone; exiting")
                status = 1
                break
            if face.lifecycle is not None:  # changes the runner made: transition events
                link.poll_state(full, face.lifecycle.seen, face.lifecycle.epoch)
    if status == 0:
        # a runner stopped at the same time (Ctrl-C to both) is not waited for long
        ok, reason = request("unload_component", {"name": full}, wait_s=5.0)
        if not ok:
            _say(who, f"warning: unload refused: {reason}")
    face.close()
    node.destroy_node()
    rclpy.try_shutdown(context=node.context)
    return status


class _RunnerLink:
    """A launcher's Tuner and Lifecycle: forwards to its runner's ~/tune_component and
    ~/lifecycle_component.

    The face validated a value already (with the declaration the runner sent), so a
    tune call does not wait: a parameter callback must not hold up the launcher's
    executor. A refusal by the runner is printed. A lifecycle call waits for the
    runner's answer in the service's thread; the executor's other thread takes it.
    """

    def __init__(self, node: Any, runner: str, who: str) -> None:
        from rcl_interfaces.srv import SetParametersAtomically
        from rclpy.callback_groups import ReentrantCallbackGroup

        self.node = node
        self.who = who
        self.runner = runner
        self.client = node.create_client(SetParametersAtomically, f"{runner}/tune_component")
        self.lifecycle_client = node.create_client(
            SetParametersAtomically,
            f"{runner}/lifecycle_component",
            callback_group=ReentrantCallbackGroup(),
        )

    # -- lifecycle ---------------------------------------------------------------------
    def lifecycle_state(self, component: str) -> str:
        return str(self._ask({"name": component}).get("state", "unknown"))

    def change_state(self, component: str, transition: int | str) -> TransitionOutcome:
        answer = self._ask({"name": component, "transition": transition})
        return TransitionOutcome(**answer["outcome"])

    def _ask(self, values: dict[str, Any], timeout_s: float = 30.0) -> dict[str, Any]:
        done = threading.Event()
        future = self.lifecycle_client.call_async(_request(values))
        future.add_done_callback(lambda f: done.set())
        if not done.wait(timeout_s) or future.result() is None:
            raise RtcfError(f"{self.runner}/lifecycle_component did not answer")
        answer: dict[str, Any] = json.loads(future.result().result.reason)
        if "error" in answer:
            raise RtcfError(str(answer["error"]))
        return answer

    def poll_state(self, component: str, seen: Callable[[int, int], None], epoch: int) -> None:
        """Ask for the state without waiting; ``seen(state, epoch)`` gets the answer."""
        if not self.lifecycle_client.service_is_ready():
            return
        future = self.lifecycle_client.call_async(_request({"name": component}))

        def done(f: Any) -> None:
            result = f.result()
            if result is not None and result.result.successful:
                state = json.loads(result.result.reason).get("state", "")
                seen(STATE_IDS.get(state, 0), epoch)

        future.add_done_callback(done)

    # -- tuning ------------------------------------------------------------------------

    def set_parameter(self, component: str, name: str, value: Any) -> Any:
        self._send({"name": component, f"param.{name}": value})
        return value

    def set_log_level(self, component: str, level: int | str) -> None:
        self._send({"name": component, "log_level": int(level)})

    def _send(self, values: dict[str, Any]) -> None:
        future = self.client.call_async(_request(values))

        def done(f: Any) -> None:
            result = f.result()
            if result is not None and not result.result.successful:
                _say(self.who, f"error: the runner refused a change: {result.result.reason}")

        future.add_done_callback(done)


def _request(values: dict[str, Any]) -> Any:
    """A SetParametersAtomically request carrying ``values``."""
    from rcl_interfaces.msg import Parameter
    from rcl_interfaces.srv import SetParametersAtomically
    from rclpy.parameter import Parameter as PyParameter

    req = SetParametersAtomically.Request()
    req.parameters = [
        Parameter(name=k, value=PyParameter(k, value=v).get_parameter_value())
        for k, v in values.items()
    ]
    return req


class _Presence:
    """Which nodes the graph shows; a node is gone once seen and then missed 3 times.

    Discovery is gradual: right after start a node may not yet see a peer it
    already talks to, so absence alone proves nothing. A process killed with
    SIGKILL leaves the graph when DDS drops its participant (Fast DDS: after its
    lease, 20 s by default).
    """

    def __init__(self) -> None:
        self.seen: set[str] = set()
        self.missed: dict[str, int] = {}

    def update(self, node: Any) -> None:
        alive = {f"{ns.rstrip('/')}/{n}" for n, ns in node.get_node_names_and_namespaces()}
        self.seen |= alive
        for name in self.seen:
            self.missed[name] = 0 if name in alive else self.missed.get(name, 0) + 1

    def gone(self, name: str) -> bool:
        return name in self.seen and self.missed.get(name, 0) >= 3


def _plain(v: Any) -> Any:
    return list(v) if isinstance(v, tuple) else v
