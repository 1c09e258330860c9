"""``rt_runner`` and ``rt_launcher`` as ROS 1 nodes (what roslaunch starts).

The executables are ``ros1/rtcf/rt_runner`` and ``ros1/rtcf/rt_launcher`` (a ROS
package ``rtcf`` that roslaunch finds on ``ROS_PACKAGE_PATH``); they call
:func:`runner_main` and :func:`launcher_main`. See docs/ros1.md.

``rt_runner __name:=NAME`` is a rospy node whose private parameters (``~mode``,
``~frequency``, ...) are the runner's settings. It serves, under its own name (so
several runners share one master):

* ``~load_component`` (``rtcf_msgs/LoadComponent``) and ``~unload_component``
  (``rtcf_msgs/UnloadComponent``); a refusal answers ``success: false`` and says why;
* ``~activate_rt_loop`` and ``~deactivate_rt_loop`` (``std_srvs/Trigger``), for mode
  ``wait_for_trigger``;
* ``~get_runner_info`` (``rtcf_msgs/GetRunnerInfo``): the original's introspection
  message; ``~introspect`` (``std_srvs/Trigger``, JSON) comes from the bridge;
* ``~set_component_log_level`` (``roscpp/SetLoggerLevel``: ``logger`` is the
  component's full name, ``level`` debug ... fatal): what a launcher forwards when
  rqt_logger_level sets its logger ``ros.rtcf.<component>``.

Before each load it copies the parameter server's tree into the worker, so a
component reads its private (``~gain``), namespace and absolute parameters as the
original's node handles did. Requests are served by the main thread between runs,
as with ROS 2 (``_ros2_nodes``).

``rt_launcher PACKAGE TYPE [-f|--is_first] __name:=NAME from:=to ...`` (or the
private parameters ``~rt_package``/``~rt_type``) asks its runner (``~runner``,
default ``rt_runner`` in the launcher's namespace) to load the class as a component
named like the launcher node, stays alive, and asks for the unload when it gets
SIGINT or SIGTERM. The runner unloads the components of launchers that vanish
(killed); a launcher whose runner vanishes exits with status 1 and a message.

rqt_logger_level shows a component as its launcher's node, so the launcher holds the
component's logger ``ros.rtcf.<component>`` (rospy's ``~get_loggers`` lists it, at the
runner's level for it) and forwards a ``~set_logger_level`` of it to the runner's
``~set_component_log_level``.
"""

from __future__ import annotations

import json
import sys
import threading
import time
import xmlrpc.client
from typing import TYPE_CHECKING, Any

from .._core._errors import Location, RtcfError
from .._core._faults import FailurePolicy
from .._core._lane_names import lane_from_params
from .._core._log import LogLevel
from .._core._rates import Rate
from .._core._runner import ComponentSpec
from .._core._settings import RunnerSettings
from .._launch._robot_descriptions import read as read_description
from .._launch._rosconsole import from_environment as rosconsole_config
from .._runtime._request_fields import RequestRefused, check_request
from .._runtime._requests import Request, RequestQueue, serve_request, stop_on_signals
from .._runtime._usage import help_printed, launcher_usage, runner_usage

if TYPE_CHECKING:
    from ._face import ComponentLogger

WATCH_EVERY_S = 1.0
MISSES_TO_GONE = 3  # a node is gone after this many failed look-ups in a row


def _say(who: str, text: str) -> None:
    print(f"{who}: {text}", file=sys.stderr, flush=True)


def _msgs() -> tuple[Any, Any]:
    try:
        import rtcf_msgs.msg
        import rtcf_msgs.srv
    except ImportError as exc:
        raise RtcfError(
            f"rtcf_msgs is not generated ({exc}); run scripts/setup-ros1 (docs/ros1.md)"
        ) from None
    return rtcf_msgs.msg, rtcf_msgs.srv


def _ros1() -> tuple[Any, Any, Any]:
    """rospy, and rtcf_msgs' msg and srv modules: what both nodes need first."""
    msg, srv = _msgs()
    from ._bridge import _import_rospy

    return _import_rospy(), msg, srv


# -- presence on the master ------------------------------------------------------------


class _Timeout(xmlrpc.client.Transport):
    # never socket.setdefaulttimeout: the bridge needs the process default unchanged
    def make_connection(self, host: Any) -> Any:
        conn = super().make_connection(host)
        conn.timeout = 2.0
        return conn


def node_alive(name: str, caller: str) -> bool:
    """Whether ``name`` is registered on the master and its XML-RPC server answers.

    A node killed with SIGKILL stays registered; its server no longer answers.
    """
    import rosgraph

    try:
        uri = rosgraph.Master(caller).lookupNode(name)
    except Exception:  # unknown to the master, or the master is gone
        return False
    try:
        proxy: Any = xmlrpc.client.ServerProxy(uri, transport=_Timeout())
        code, _, _ = proxy.getPid(caller)
        return bool(code == 1)
    except Exception:
        return False


class _Watch:
    """Counts failed look-ups per node; ``gone`` after MISSES_TO_GONE in a row."""

    def __init__(self, caller: str) -> None:
        self.caller = caller
        self.missed: dict[str, int] = {}

    def gone(self, name: str) -> bool:
        if node_alive(name, self.caller):
            self.missed[name] = 0
            return False
        self.missed[name] = self.missed.get(name, 0) + 1
        return self.missed[name] >= MISSES_TO_GONE


# -- the runner ------------------------------------------------------------------------


def runner_main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    if help_printed(argv, runner_usage, "ros1"):
        return 0
    try:
        rospy, msg, srv = _ros1()
        from ._bridge import Ros1Bridge

        bridge = Ros1Bridge("rt_runner", None, argv[1:])
    except RtcfError as exc:
        _say("rt_runner", f"error: {exc}")
        return 1
    from roscpp.srv import SetLoggerLevel, SetLoggerLevelResponse
    from std_srvs.srv import Trigger, TriggerResponse

    from .._runtime._supervisor import WorkerRunner
    from ._face import level_of, mirror_level

    name = bridge.node_name
    try:
        settings = RunnerSettings.from_params(
            _private_params(rospy), where=f"rt_runner {name}"
        )
        _robot_description(rospy, settings, name)
    except RtcfError as exc:
        _say(name, f"error: {exc}")
        bridge.shutdown()
        return 1
    for note in getattr(settings, "notes", []):
        _say(name, note)
    # ROSCONSOLE_CONFIG_FILE (roslaunch's <env>): the components' start levels, read
    # once at start, as rosconsole reads it when a node starts
    console = rosconsole_config()
    for warning in console.warnings if console is not None else []:
        _say(name, f"warning: {warning}")
    if console is not None and console.sources:
        _say(name, console.describe())
    runner = WorkerRunner(settings, name=name, bridge=bridge)
    requests = RequestQueue(runner)
    submit = requests.submit
    launchers: dict[str, str] = {}  # component -> launcher node that asked for it
    lock = threading.Lock()  # launchers: the watch thread reads it too

    def on_load(request: Any) -> Any:
        try:  # every field type-checked before anything is imported
            check_request("load_component", {
                "module": request.package, "class": request.type, "name": request.name,
                "namespace": request.namespace, "remaps": list(request.remaps),
                "is_first": bool(request.is_first),
                "topics_ignore_for_graph": request.topics_ignore_for_graph,
                "launcher": request.launcher}, named={"module": "package", "class": "type"})
            spec, _ = _spec(request)  # what can be refused without the worker, is
            runner.admits("loads", spec.module, spec.full_name, spec.class_name)
        except RtcfError as exc:
            return srv.LoadComponentResponse(success=False, message=str(exc))
        req = submit("load", request)
        return srv.LoadComponentResponse(success=req.ok, message=req.reason)

    def on_unload(request: Any) -> Any:
        try:
            check_request("unload_component", {"name": request.name})
            runner.admits("unloads", component=str(request.name))
        except RequestRefused as exc:
            return srv.UnloadComponentResponse(success=False, message=str(exc))
        req = submit("unload", str(request.name))
        return srv.UnloadComponentResponse(success=req.ok, message=req.reason)

    def trigger(kind: str) -> Any:
        def on_trigger(request: Any) -> Any:
            req = submit(kind, None)
            return TriggerResponse(success=req.ok, message=req.reason)

        return on_trigger

    def on_info(request: Any) -> Any:
        return srv.GetRunnerInfoResponse(runner_info=runner_info(msg, runner.introspect()))

    def on_component_level(request: Any) -> Any:
        # rospy's service thread; WorkerRunner.set_log_level is thread-safe
        component = str(request.logger)
        try:
            level = level_of(str(request.level))
            runner.set_log_level(component, level)
        except RtcfError as exc:  # the caller's ServiceProxy raises ServiceException
            raise rospy.ServiceException(str(exc)) from None
        mirror_level(component, level)  # the runner's own ros.rtcf.<component> logger
        return SetLoggerLevelResponse()

    services = [
        rospy.Service("~load_component", srv.LoadComponent, on_load),
        rospy.Service("~unload_component", srv.UnloadComponent, on_unload),
        rospy.Service("~activate_rt_loop", Trigger, trigger("activate")),
        rospy.Service("~deactivate_rt_loop", Trigger, trigger("deactivate")),
        rospy.Service("~get_runner_info", srv.GetRunnerInfo, on_info),
        rospy.Service("~set_component_log_level", SetLoggerLevel, on_component_level),
    ]
    stopping = threading.Event()

    def watch() -> None:  # a launcher killed with SIGKILL never asks for its unload
        presence = _Watch(name)
        while not stopping.wait(WATCH_EVERY_S):
            with lock:
                pairs = list(launchers.items())
            for component, launcher in pairs:
                if launcher and presence.gone(launcher):
                    with lock:
                        launchers.pop(component, None)
                    _say(name, f"launcher {launcher} is gone; unloading {component}")
                    requests.put("unload", component)

    watcher = threading.Thread(target=watch, name="rtcf-ros1-watch", daemon=True)

    # a signal's STOP, kept past clear_stop: the components' safe_stop hooks run
    stop_asked = stop_on_signals(lambda: runner.request_stop(abort=True))

    def load(payload: Any) -> str:
        spec, launcher = _spec(payload)
        if console is not None:
            spec.log_level = console.component_level(spec.full_name, LogLevel.INFO)
        # the parameter server as it is now: private, namespace and absolute names
        tree = rospy.get_param("/", {})
        runner.set_parameters(_leaves(tree))
        private = rospy.get_param(spec.full_name, {})  # the launcher's: on_error, fallback
        private = private if isinstance(private, dict) else {}
        spec.policy = FailurePolicy.from_params(private, spec.full_name)
        spec.rate = Rate.from_params(private, spec.full_name)  # rate, every, phase
        spec.lane = lane_from_params(private, spec.full_name)
        runner.load(spec, launcher=launcher)
        try:  # the graph with it: a cycle or a second producer refuses this load
            runner.describe()  # and leaves the runner running with the others
        except RtcfError:
            runner.unload(spec.full_name)
            raise
        with lock:
            launchers[spec.full_name] = launcher
        _say(name, f"loaded {spec.full_name} ({spec.module}.{spec.class_name})"
                   f"{runner.lanes.said(spec.full_name)}")
        return f"loaded {spec.full_name}"

    def unloaded(full: str) -> str:
        with lock:
            launchers.pop(full, None)
        return f"unloaded {full}"

    def serve(req: Request) -> None:
        serve_request(req, runner, lambda text: _say(name, text), load, unloaded)

    status = 0
    iterations = 0
    try:
        runner.start()
        watcher.start()
        clock = ", on /clock time (use_sim_time)" if settings.use_sim_time else ""
        _say(name, f"ready: {settings.frequency:g} Hz, mode {settings.mode}{clock}")

        def run() -> None:
            nonlocal iterations
            _say(name, "running")
            iterations += runner.run(None).iterations

        requests.serve_until_stopped(
            serve, lambda: stop_asked.is_set() or rospy.is_shutdown(), run
        )
    except RtcfError as exc:
        _say(name, f"error: {exc}")
        status = 1
    finally:
        stopping.set()
        # requests that came in meanwhile are refused, not left hanging
        requests.refuse_pending("the runner is shutting down")
        for service in services:
            service.shutdown()
        for err in runner.shutdown() if runner.process is not None else []:
            _say(name, f"error: {err}")
            status = 1
        runner.close()
        bridge.shutdown()
        _say(name, f"stopped after {iterations} iterations")
    return status


def _robot_description(rospy: Any, settings: RunnerSettings, name: str) -> None:
    """The runner's robot description, as ros_control finds it: its own parameter, else
    ``robot_description`` searched from its namespace up (a launch file's
    ``<param name="robot_description" command="xacro ..."/>``); parsed here, so that a
    broken one is one line naming the parameter, and given to the worker."""
    if settings.robot_description or settings.robot_description_file:
        return
    key = rospy.search_param("robot_description")
    text = rospy.get_param(key, None) if key else None
    if not isinstance(text, str) or not text.strip():
        return
    described = read_description(text, Location(key), f"parameter {key}")
    settings.robot_description = text
    _say(name, described.summary())


def _private_params(rospy: Any) -> dict[str, Any]:
    values = rospy.get_param("~", {})
    return dict(values) if isinstance(values, dict) else {}


def _leaves(tree: Any, prefix: str = "") -> dict[str, Any]:
    """The parameter server's tree as absolute leaf names (``/rtcf/sum1/gain``)."""
    out: dict[str, Any] = {}
    if isinstance(tree, dict) and tree:
        for key, value in tree.items():
            out.update(_leaves(value, f"{prefix}/{key}"))
    elif prefix:
        out[prefix] = tree
    return out


def _spec(request: Any) -> tuple[ComponentSpec, str]:
    missing = [k for k in ("package", "type", "name") if not str(getattr(request, k, ""))]
    if missing:
        raise RtcfError(
            "a load request needs package, type and name; missing: " + ", ".join(missing)
        )
    remaps = []
    for rule in request.remaps:
        src, sep, dst = str(rule).partition(":=")
        if not sep or not src or not dst:
            raise RtcfError(f"remap {rule!r} is not of the form from:=to")
        remaps.append((src, dst))
    spec = ComponentSpec(
        name=str(request.name),
        module=str(request.package),
        class_name=str(request.type),
        namespace=str(request.namespace or "/"),
        remaps=remaps,
        is_first=bool(request.is_first),
        topics_ignore_for_graph=str(request.topics_ignore_for_graph or ""),
    )
    return spec, str(request.launcher or "")


def runner_info(msg: Any, data: dict[str, Any]) -> Any:
    """The original's rtcf_msgs/RunnerInfo of :meth:`WorkerRunner.introspect`'s data."""
    ros = {c["topic"]: bool(c["ros"]) for c in data.get("connections", [])}

    def port(p: dict[str, Any], kind: int) -> Any:
        return msg.PortInfo(
            port_type=kind,
            name_remapped=str(p.get("topic", "")),
            name_unresolved=str(p.get("name", "")),
            msg_type=str(p.get("type", "")),
            connected_to_ROS=ros.get(p.get("topic", ""), False),
        )

    components = []
    for c in data.get("components", []):
        package, _, cls = str(c.get("type", "")).rpartition(".")
        components.append(msg.ComponentInfo(
            name=str(c["name"]),
            package=package,
            type=cls,
            input_ports=[port(p, msg.PortInfo.TYPE_INPUT) for p in c.get("inputs", [])],
            output_ports=[port(p, msg.PortInfo.TYPE_OUTPUT) for p in c.get("outputs", [])],
        ))
    connections = [
        msg.ConnectionInfo(
            name=str(c["topic"]),
            type=str(c["type"]),
            publishing_components=list(c["publishers"]),
            subscribing_components=list(c["subscribers"]),
            connected_to_ROS=bool(c["ros"]),
        )
        for c in data.get("connections", [])
    ]
    return msg.RunnerInfo(
        components=components,
        connections=connections,
        component_order=[str(n) for n in data.get("order", [])],
    )


# -- the launcher ------------------------------------------------------------------------


def launcher_main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    if help_printed(argv, launcher_usage, "ros1"):
        return 0
    try:
        rospy, _, srv = _ros1()
        import rosgraph
        import rosgraph.names

        from ._bridge import _keep_root_logging

        if not rosgraph.is_master_online():
            raise RtcfError(f"no ROS master answers at {rosgraph.get_master_uri()}")
    except RtcfError as exc:
        _say("rt_launcher", f"error: {exc}")
        return 1
    words = rospy.myargv(argv)[1:]
    is_first = any(w in ("-f", "--is_first") for w in words)
    positional = [w for w in words if not w.startswith("-")]
    with _keep_root_logging():
        rospy.init_node("rt_launcher", argv=argv, disable_signals=True)
    me = rospy.get_name()
    who = f"rt_launcher {me}"
    params = _private_params(rospy)
    package = positional[0] if positional else str(params.get("rt_package") or "")
    cls = positional[1] if len(positional) > 1 else str(params.get("rt_type") or "")
    if not package or not cls:
        _say(who, "error: give PACKAGE TYPE (or the ~rt_package and ~rt_type parameters)")
        rospy.signal_shutdown("no component")
        return 2
    # a stop while waiting for the runner ends the wait; during the load request, it
    # unloads right after it
    stop = stop_on_signals()
    namespace = rospy.get_namespace()
    given = str(params.get("runner") or "")
    candidates = [rospy.resolve_name(given)] if given else runner_candidates(namespace)
    runner = _await_runner(rospy, candidates, 30.0, stop)
    if runner is None and stop.is_set():
        _say(who, "stopped before a runner answered")
        rospy.signal_shutdown("stopped")
        return 0
    if runner is None:
        where = " or ".join(f"{c}/load_component" for c in candidates)
        _say(who, f"error: no runner answers at {where} within 30 s; is it running? "
             "(~runner names another)")
        rospy.signal_shutdown("no runner")
        return 1
    remaps = [
        f"{src}:={dst}" for src, dst in rosgraph.names.load_mappings(argv).items()
    ]
    request = srv.LoadComponentRequest(
        package=package,
        type=cls,
        name=me.rpartition("/")[2],
        namespace=namespace,
        remaps=remaps,
        is_first=is_first or bool(params.get("is_first", False)),
        topics_ignore_for_graph=str(params.get("topics_ignore_for_graph") or ""),
        launcher=me,
    )

    def call(service: str, cls_: Any, req: Any, wait_s: float) -> tuple[bool, str]:
        path = f"{runner}/{service}"
        try:
            rospy.wait_for_service(path, timeout=wait_s)
            answer = rospy.ServiceProxy(path, cls_)(req)
        except rospy.ROSException:
            return False, f"no runner answers at {path}"
        except rospy.ServiceException as exc:
            return False, f"{path} failed: {exc}"
        return bool(answer.success), str(answer.message)

    ok, reason = call("load_component", srv.LoadComponent, request, 30.0)
    if not ok:
        _say(who, f"error: {runner} refused to load {package}.{cls}: {reason}")
        rospy.signal_shutdown("refused")
        return 1
    full = namespace.rstrip("/") + "/" + request.name
    logger = _LevelLink(runner, full, who).logger(_runner_level(runner, full))
    _say(who, f"loaded into {runner}")
    status = 0
    presence = _Watch(me)
    last_check = time.monotonic()
    while not stop.wait(0.1):
        if rospy.is_shutdown():  # e.g. a new node of the same name took over
            _say(who, "error: rospy shut down; exiting")
            return 1
        now = time.monotonic()
        if now - last_check >= WATCH_EVERY_S:
            last_check = now
            if presence.gone(runner):
                _say(who, f"error: the runner {runner} is gone; exiting")
                status = 1
                break
    logger.rtcf_on_level = None  # the component is leaving: no more forwarding
    if status == 0:
        # a runner stopped at the same time (Ctrl-C to both) is not waited for long
        ok, reason = call(
            "unload_component", srv.UnloadComponent, srv.UnloadComponentRequest(name=full), 5.0
        )
        if ok:
            _say(who, f"unloaded from {runner}")
        else:
            _say(who, f"warning: unload refused: {reason}")
    rospy.signal_shutdown("rt_launcher stopped")
    return status


def runner_candidates(namespace: str, name: str = "rt_runner") -> list[str]:
    """Where a launcher without ``~runner`` looks for its runner: ``name`` in its own
    namespace, then in each one above it to the root, nearest first (as roslaunch's
    ``searchParam`` looks for a parameter): ``/rtcf/rt_runner`` in ``<group
    ns="rtcf">`` beside its runner, ``/rt_runner`` for a group below a top-level one."""
    parts = [p for p in namespace.strip("/").split("/") if p]
    return ["/" + "/".join([*parts[:k], name]) for k in range(len(parts), -1, -1)]


def _await_runner(
    rospy: Any, candidates: list[str], timeout_s: float, stop: threading.Event,
) -> str | None:
    """The first of ``candidates`` (nearest first) whose load service is up, waiting up to
    ``timeout_s`` for one to come; None if none did, or ``stop`` was set."""
    deadline = time.monotonic() + timeout_s
    while not stop.is_set():
        for runner in candidates:
            try:
                rospy.wait_for_service(f"{runner}/load_component", timeout=0.05)
                return runner
            except rospy.ROSException:
                pass
        if time.monotonic() >= deadline or rospy.is_shutdown():
            return None
        stop.wait(0.1)
    return None


def _runner_level(runner: str, component: str) -> int:
    """The component's log level as its runner has it (``~introspect``); else info."""
    import rospy
    from std_srvs.srv import Trigger

    from ._face import level_number

    try:
        answer = rospy.ServiceProxy(f"{runner}/introspect", Trigger)()
        data = json.loads(answer.message)
        for info in data.get("components", []):
            if info.get("name") == component:
                return level_number(info.get("log_level"))
    except Exception:  # an older runner, or none: info, as the runner starts it
        pass
    return level_number(None)


class _LevelLink:
    """A launcher's hook on ``ros.rtcf.<component>``: a level set there (rqt_logger_level
    through rospy's ``~set_logger_level``) goes to the runner's
    ``~set_component_log_level``. Called in rospy's service thread; the reply to
    ``set_logger_level`` waits until the runner has the level."""

    def __init__(self, runner: str, component: str, who: str) -> None:
        import rospy
        from roscpp.srv import SetLoggerLevel

        self.component = component
        self.who = who
        self.path = f"{runner}/set_component_log_level"
        self.proxy = rospy.ServiceProxy(self.path, SetLoggerLevel)

    def logger(self, level: int) -> ComponentLogger:
        from ._face import ComponentLogger, component_logger

        logger = component_logger(self.component, level, self)
        assert isinstance(logger, ComponentLogger)
        return logger

    def __call__(self, level: int) -> None:
        import logging

        import rospy

        name = logging.getLevelName(int(level))
        try:
            self.proxy(logger=self.component, level=name)
        except (rospy.ServiceException, rospy.ROSException) as exc:
            _say(self.who, f"warning: {self.path} refused level {name}: {exc}")


# -- introspection from the command line --------------------------------------------------


def fetch_introspection_ros1(runner: str, timeout_s: float = 10.0) -> dict[str, Any]:
    """Ask a running ROS 1 runner (rt_runner, or rtcf launch --middleware ros1) what it
    holds: its ``~introspect`` service (std_srvs/Trigger, JSON)."""
    from ._bridge import _import_rospy, _keep_root_logging

    rospy = _import_rospy()
    import rosgraph
    from std_srvs.srv import Trigger

    if not rosgraph.is_master_online():
        raise RtcfError(f"no ROS master answers at {rosgraph.get_master_uri()}")
    with _keep_root_logging():
        rospy.init_node("rtcf_cli", anonymous=True, disable_signals=True)
    service = rospy.resolve_name(runner).rstrip("/") + "/introspect"
    try:
        try:
            rospy.wait_for_service(service, timeout=timeout_s)
        except rospy.ROSException:
            raise RtcfError(
                f"no runner answers at {service} within {timeout_s:g} s; is it running "
                "(rt_runner, or rtcf launch ... --middleware ros1) on this ROS_MASTER_URI? "
                "name it with --runner"
            ) from None
        try:
            answer = rospy.ServiceProxy(service, Trigger)()
        except rospy.ServiceException as exc:
            raise RtcfError(f"{service} failed: {exc}") from None
        data: dict[str, Any] = json.loads(answer.message)
        return data
    finally:
        rospy.signal_shutdown("done")
