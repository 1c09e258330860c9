"""The ROS 1 bridge: mapped ports as ROS 1 topics, in the supervisor process only.

rospy lives here and never in the worker (../shared/design.md, decisions 1 and 2).
The supervisor becomes a rospy node named after the runner. rospy's own threads
deliver subscribed messages, which go straight into the input's mailbox (the loop
picks up the newest one at the start of its next iteration), and send what was
published; one thread of the bridge sleeps on the doorbell that the worker rings
after each output record, then drains the output rings and publishes.

rospy allows one node per process, for the life of the process: ``init_node``
cannot be called again with another name, and after ``signal_shutdown`` no node can
start in that process again. So there is one :class:`Ros1Bridge` per supervisor
process, and it lives as long as that process.

Messages cross as bytes both ways; no genpy message object is built on the way.
Publishers are made with the real message class, so the master, ``rostopic`` and
rqt know the type, its md5 sum and its definition; what they publish is a raw
message (a ``rospy.AnyMsg`` of that type) whose ``serialize`` writes the bytes
that the worker produced. Subscriptions use the same raw class: they register with
the real type (a publisher checks the md5 sum) and rospy hands over the bytes
undeserialized. The worker's float, int and bool payloads already are the ROS 1
serialization of std_msgs Float64, Int64 and Bool; str (String) and a 1-D float
numpy array (Float64MultiArray) get their length prefix and layout added here.

QoS, as far as ROS 1 has one: ``ros_qos_depth`` is the queue size (default 10
messages per connection; older ones are dropped when a peer falls behind), and
``ros_qos_durability`` transient_local latches the last message for late subscribers
(volatile, the default: not latched). TCPROS is always reliable, so
``ros_qos_reliability`` changes nothing.

``~iteration_info`` carries one rtcf_msgs/IterationInfo per iteration, the
original's type (``stamp``: when the iteration started, in ROS time: its scheduled
start plus its wake-up jitter; ``duration_ns``: its calculation time), packed here by
hand. Without the generated
rtcf_msgs (scripts/setup-ros1 makes them) it is a std_msgs/Float64MultiArray as
with ROS 2: ``[iteration, stamp (s), calculation duration (s), wake-up jitter (s)]``.
``~introspect`` (std_srvs/Trigger) answers with the runner's introspection data as
JSON.

A node per component, as the ROS 2 bridge makes, is impossible in one rospy process;
the components' records still reach /rosout under their own names (see :meth:`log`),
and what tools need of a component lives in this node under the component's name
(:mod:`rtcf._ros1._face`): a dynamic_reconfigure server for its tunable parameters
and a logger ``ros.rtcf.<component>`` that rospy's ``~get_loggers`` and
``~set_logger_level`` (rqt_logger_level) list and set, down to the worker.

Parameters: at start (:meth:`share_parameters`) the parameter server's tree joins
the runner's, and the runner's (a launch file's) goes to the server; the launch file
wins where both set a name, as with roslaunch.
"""

from __future__ import annotations

import functools
import json
import logging
import socket
import struct
import sys
import threading
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .._core._errors import ConfigurationError, RtcfError
from .._core._log import LogRecord
from .._core._params import ParameterStore
from .._core._rings import Mailbox, Ring
from .._core._settings import RunnerSettings
from .._core._timing import (
    COL_CALC,
    COL_JITTER,
    COL_SCHEDULED,
    ITERATION_INFO_BYTES,
    ITERATION_INFO_LABELS,
    TimingAggregate,
    iteration_info_doubles,
)
from .._runtime._doorbell import ClockFeed, Doorbell
from .._runtime._health import diagnostic_array, health
from .._runtime._middleware import import_client, mapped_message_class
from .._runtime._port_channels import MailboxFanOut, MappedPort, read_record
from ._face import rosconsole_logger_name

if TYPE_CHECKING:
    from .._runtime._supervisor import LiveStatus, WorkerRunner
    from ._face import ComponentFace

QUEUE_SIZE = 10  # until configure() gives the runner's ros_qos_depth
ROSOUT_QUEUE_SIZE = 100  # what rospy uses for its own /rosout publisher
DRAIN_TIMEOUT_S = 0.05  # how often the publishing thread looks whether to end
CONNECT_TIMEOUT_S = 1.0  # how long open() waits for peers the master already knows

_FIXED_SIZE = {"float": 8, "int": 8, "bool": 1}
_U32 = struct.Struct("<I")
_EMPTY_LAYOUT = b"\x00" * 8  # MultiArrayLayout: no dims, data_offset 0

# rtcf's levels (Python's numbers) to rosgraph_msgs/Log's bit values
_LEVELS = ((50, 16), (40, 8), (30, 4), (20, 2))  # FATAL, ERROR, WARN, INFO; else DEBUG 1


def _import_rospy() -> Any:
    return import_client(
        "rospy", "ros1", "on Debian run scripts/setup-ros1 and use .venv-ros1 (see docs/ros1.md)"
    )


def message_class(port: MappedPort) -> type:
    """The ROS 1 (genpy) message class a mapped port is published or subscribed as."""
    return mapped_message_class(
        port, ros2=False, install="e.g. apt-get install python3-std-msgs"
    )


@functools.cache
def raw_class(cls: type) -> type:
    """A message class of ``cls``'s type whose instances carry serialized bytes (``_buff``)."""
    from rospy import AnyMsg

    return type(
        f"Raw{cls.__name__}",
        (AnyMsg,),
        {
            "__slots__": (),
            "_type": cls._type,  # type: ignore[attr-defined]
            "_md5sum": cls._md5sum,  # type: ignore[attr-defined]
            "_full_text": cls._full_text,  # type: ignore[attr-defined]
            "_has_header": False,  # rospy must not set header.seq: the bytes are final
        },
    )


def to_wire(kind: str, payload: bytes) -> bytes:
    """The ROS 1 serialization of what the worker's codec wrote for ``kind``."""
    if kind == "str":
        return _U32.pack(len(payload)) + payload
    if kind == "float_array":
        return _EMPTY_LAYOUT + _U32.pack(len(payload) // 8) + payload
    return payload  # float, int, bool and ros1 are the same bytes


def from_wire(kind: str, cls: type, buff: bytes) -> bytes | None:
    """What the worker's codec reads for ``kind``, from a ROS 1 message; None if malformed."""
    if kind in _FIXED_SIZE:
        return buff if len(buff) == _FIXED_SIZE[kind] else None
    if kind == "str":
        return buff[4:] if len(buff) >= 4 and _U32.unpack_from(buff)[0] == len(buff) - 4 else None
    if kind == "float_array":  # the layout may have dims: let genpy skip it
        data = cls().deserialize(buff).data
        return struct.pack(f"<{len(data)}d", *data)
    return bytes(buff)


def log_level(level: int) -> int:
    """rosgraph_msgs/Log's level (1, 2, 4, 8, 16) of an rtcf level (10 ... 50)."""
    for at_least, ros in _LEVELS:
        if level >= at_least:
            return ros
    return 1


def node_like_name(component: str) -> str:
    """'/rtcf/sum1' as a ROS 1 node name (absolute): what rqt_console shows as Node."""
    return "/" + "/".join(p for p in component.split("/") if p)


class Ros1Bridge:
    """A rospy node for one runner; moves messages between ROS 1 and the run's channels."""

    def __init__(
        self,
        name: str = "rt_runner",
        namespace: str | None = None,
        args: list[str] | None = None,
    ) -> None:
        """Start the node ``namespace/name`` (default: ROS_NAMESPACE), with remaps ``args``.

        Fails at once, with a clear error, when no master answers at ROS_MASTER_URI.
        """
        rospy = _import_rospy()
        import rosgraph
        from diagnostic_msgs.msg import DiagnosticArray
        from rosgraph_msgs.msg import Log

        self._rospy = rospy
        if rospy.core.is_shutdown():
            raise RtcfError(
                "rospy was shut down in this process and cannot start a node again: "
                "one Ros1Bridge per process"
            )
        if not rosgraph.is_master_online():
            raise RtcfError(
                f"no ROS master answers at {rosgraph.get_master_uri()}; start roscore "
                "or set ROS_MASTER_URI"
            )
        ns = node_like_name(namespace) if namespace and namespace.strip("/") else None
        self._owns_node = not rospy.core.is_initialized()
        if self._owns_node:
            if ns is not None:
                # what ROS_NAMESPACE or __ns:= would give; rospy reads those at import only
                rospy.names._set_caller_id(f"{ns}/unnamed")
            with _keep_root_logging():
                rospy.init_node(name, argv=[sys.argv[0], *(args or [])], disable_signals=True)
        else:  # an rt_runner's own node: use it if it is the one asked for
            current = rospy.get_name()
            wanted = f"{ns or current.rpartition('/')[0]}/{name}"
            if current != wanted:
                raise RtcfError(
                    f"this process already is the ROS 1 node {current}, not {wanted}: "
                    "rospy allows one node per process"
                )
        self.node_name: str = rospy.get_name()
        self._rosout = rospy.Publisher(
            "/rosout", Log, latch=True, queue_size=ROSOUT_QUEUE_SIZE
        )
        self._diagnostics = rospy.Publisher(
            "/diagnostics", DiagnosticArray, queue_size=QUEUE_SIZE
        )
        self._lock = threading.Lock()
        self._open = False  # whether a run's channels are there
        self._queue_size = QUEUE_SIZE
        self._latch = False
        # publishers and subscribers outlive a run: a load or an unload restarts the loop,
        # and ROS 1 peers would need a new connection (and lose messages) each time
        self._publishers: dict[str, tuple[Any, Any]] = {}  # topic: (class and QoS, topic)
        self._subscribers: dict[str, tuple[Any, Any]] = {}
        self._outputs: list[tuple[Ring, Any, Any, str]] = []  # ring, publisher, raw msg, kind
        self._inputs: dict[str, tuple[Mailbox | MailboxFanOut, Callable[..., bytes | None]]] = {}
        self._clock_sub: Any = None
        self._clock_box: ClockFeed | None = None
        self._info_pub: Any = None
        self._info_raw: Any = None
        self._info_prefix = b""
        self._info_offset = 0
        self._info_typed = False
        self._introspect_srv: Any = None
        self._faces: dict[str, ComponentFace] = {}  # per loaded component (_ros1_face)
        self._stop = threading.Event()
        self.doorbell = Doorbell.create()  # rung by the worker: outputs to publish
        _wait_for_connections([(self._rosout, "/rosout", "sub")], CONNECT_TIMEOUT_S)
        self._thread = threading.Thread(target=self._run, name="rtcf-ros1", daemon=True)
        self._thread.start()

    def configure(self, settings: RunnerSettings, runner: WorkerRunner) -> None:
        """The runner's QoS for mapped topics, its ``~iteration_info`` topic and its
        ``~introspect`` service (std_srvs/Trigger; the answer's message is JSON)."""
        rospy = self._rospy
        from std_srvs.srv import Trigger, TriggerResponse

        def on_introspect(request: Any) -> Any:
            return TriggerResponse(success=True, message=json.dumps(runner.introspect()))

        if self._introspect_srv is None:
            self._introspect_srv = rospy.Service("~introspect", Trigger, on_introspect)
        self.share_parameters(runner)
        sim = global_sim_time(runner.parameters, runner.name)
        if sim is not None and sim != settings.use_sim_time:
            # ROS 1's rule (what the original reads): simulators set the global
            # /use_sim_time; the runner's own ~use_sim_time, when given, still rules
            settings.use_sim_time = sim
            runner.log_sink(LogRecord(
                20, "rt_runner", "use_sim_time: true, from the global /use_sim_time"
            ))
        self._queue_size = settings.ros_qos_depth
        self._latch = settings.ros_qos_durability == "transient_local"
        # the rows hold CLOCK_MONOTONIC ns (or /clock ns); stamps are ROS time, which is
        # the wall clock without sim time. Taken once, so that stamps keep the loop's grid
        self._info_offset = 0
        if not settings.use_sim_time:
            self._info_offset = time.time_ns() - time.monotonic_ns()
        if settings.iteration_info and self._info_pub is None:
            info_class: type
            try:
                from rtcf_msgs.msg import IterationInfo

                info_class, self._info_typed = IterationInfo, True
            except ImportError:  # rtcf_msgs not generated: the standard type
                from std_msgs.msg import Float64MultiArray

                info_class, self._info_typed = Float64MultiArray, False
                self._info_prefix = _iteration_info_prefix()
            self._info_raw = raw_class(info_class)()
            self._info_pub = rospy.Publisher("~iteration_info", info_class, queue_size=100)

    def share_parameters(self, runner: WorkerRunner) -> None:
        """One parameter tree for the run and the ROS parameter server, before any load.

        What the master's parameter server holds (``rosparam set``, another roslaunch)
        joins the runner's tree, so components read it at configure time; then the
        runner's tree (the launch file's parameters) goes to the server, as roslaunch
        puts a launch file's parameters there. A name that both set keeps the launch
        file's value, on both sides: the launch file wins, as with roslaunch.
        """
        rospy = self._rospy
        store = runner.parameters
        try:
            server = rospy.get_param("/")
        except Exception as exc:  # the master went away: the run says so soon enough
            runner.log_sink(LogRecord(30, "rt_runner", f"parameter server: {exc}"))
            server = {}
        ours = store.names()
        for name, value in _param_leaves(server if isinstance(server, dict) else {}):
            if not _clashes(name, ours):
                store.set(name, value)
        for name in ours:
            value = store.get(name)
            try:
                rospy.set_param(name, value)
            except Exception as exc:  # None and other values XML-RPC cannot carry
                runner.log_sink(LogRecord(
                    30, "rt_runner", f"parameter {name} = {value!r} is not on the parameter "
                    f"server ({type(exc).__name__}: {exc}); the components still read it"
                ))

    def iteration_info(self, rows: Any) -> None:
        """One message per timing row (called by the supervisor as it drains the rows)."""
        pub = self._info_pub
        if pub is None or pub.get_num_connections() == 0:
            return
        offset = self._info_offset
        prefix = self._info_prefix
        raw = self._info_raw
        if self._info_typed:  # rtcf_msgs/IterationInfo: time stamp, uint64 duration_ns
            # the stamp is when the iteration started (scheduled start + wake-up jitter),
            # as the original's: the intervals between stamps show the jitter
            pack_typed = _ITERATION_INFO.pack
            for row in rows.tolist():
                start = row[COL_SCHEDULED] + max(row[COL_JITTER], 0)
                sec, nsec = divmod(start + offset, 1_000_000_000)
                raw._buff = pack_typed(sec, nsec, max(row[COL_CALC], 0))
                pub.publish(raw)
            return
        data = iteration_info_doubles(rows, offset)
        for at in range(0, len(data), ITERATION_INFO_BYTES):
            raw._buff = prefix + data[at : at + ITERATION_INFO_BYTES]
            pub.publish(raw)

    def component_loaded(self, info: dict[str, Any], runner: WorkerRunner) -> None:
        """Serve the component's tunables (a dynamic_reconfigure server under its name)
        and its logger ``ros.rtcf.<component>`` (``~set_logger_level``): see _ros1_face."""
        from ._face import ComponentFace, level_number

        full = str(info["name"])
        old = self._faces.pop(full, None)
        if old is not None:
            old.close()

        def warn(text: str) -> None:
            runner.log_sink(LogRecord(30, "rt_runner", text))

        default = level_number(runner.log_level)
        self._faces[full] = ComponentFace(info, runner, default, warn)

    def parameter_set(self, name: str, value: Any) -> None:
        """A component's params.set(): onto the parameter server, as the original's
        node handle writes it."""
        _import_rospy().set_param(name, value)

    def component_unloaded(self, name: str) -> None:
        """Take the component's dynamic_reconfigure server off the graph."""
        face = self._faces.pop(name, None)
        if face is not None:
            face.close()

    # -- per run -------------------------------------------------------------------
    def open(
        self, ports: list[MappedPort], channels: Mapping[str, Ring | Mailbox | MailboxFanOut]
    ) -> None:
        rospy = self._rospy
        actions = sorted(p.topic.rpartition("/_action/")[0] for p in ports if p.kind == "action")
        if actions:
            raise ConfigurationError(
                f"action {actions[0]} is mapped to the middleware (ros_mapping_whitelist), "
                "but actions are served on ROS 2 only (--middleware ros2); leave it out of "
                "the whitelist on ROS 1"
            )
        peers: list[tuple[Any, str, str]] = []
        with self._lock:
            self._open = True
            for direction, known_topics in (
                ("output", self._publishers), ("input", self._subscribers)
            ):  # what this run no longer maps leaves the graph
                wanted = {p.topic for p in ports if p.direction == direction}
                for topic in [t for t in known_topics if t not in wanted]:
                    known_topics.pop(topic)[1].unregister()
            for port in ports:
                cls = message_class(port)
                channel = channels[port.topic]
                if port.direction == "output":
                    assert isinstance(channel, Ring)
                    key: tuple[Any, ...] = (cls, self._queue_size, self._latch)
                    known = self._publishers.get(port.topic)
                    if known is None or known[0] != key:
                        if known is not None:
                            known[1].unregister()
                        pub = rospy.Publisher(
                            port.topic, cls, queue_size=self._queue_size, latch=self._latch
                        )
                        self._publishers[port.topic] = (key, pub)
                    pub = self._publishers[port.topic][1]
                    self._outputs.append((channel, pub, raw_class(cls)(), port.kind))
                    peers.append((pub, port.topic, "sub"))
                else:
                    assert isinstance(channel, Mailbox | MailboxFanOut)

                    def convert(
                        buff: bytes, kind: str = port.kind, cls: type = cls
                    ) -> bytes | None:
                        return from_wire(kind, cls, buff)

                    self._inputs[port.topic] = (channel, convert)
                    key = (cls, self._queue_size)
                    known = self._subscribers.get(port.topic)
                    if known is None or known[0] != key:
                        if known is not None:
                            known[1].unregister()
                        sub = rospy.Subscriber(
                            port.topic,
                            raw_class(cls),
                            self._on_message,
                            callback_args=port.topic,
                            queue_size=self._queue_size,
                        )
                        self._subscribers[port.topic] = (key, sub)
                    peers.append((self._subscribers[port.topic][1], port.topic, "pub"))
        # a subscriber that was there before the run gets the first message, too
        _wait_for_connections(peers, CONNECT_TIMEOUT_S)

    def _on_message(self, msg: Any, topic: str) -> None:
        # a thread of rospy's, one per connection
        with self._lock:  # the run may have closed its channels meanwhile
            target = self._inputs.get(topic) if self._open else None
            if target is None:
                return
            box, convert = target
            try:
                payload = convert(msg._buff)
            except Exception:  # a message that does not deserialize
                payload = None
            if payload is not None and len(payload) <= box.size:
                box.write(payload)

    def log(self, rec: LogRecord) -> None:
        """Publish a record on /rosout as the component's node (rqt_console shows it)."""
        from rosgraph_msgs.msg import Log

        msg = Log(
            level=log_level(int(rec.level)),
            name=self._source(rec.logger),
            msg=rec.format(),
            file=rosconsole_logger_name(rec.logger) if rec.logger.startswith("/") else "",
            function="update" if rec.iteration >= 0 else "",
            line=0,
            topics=[],
        )
        msg.header.stamp = self._rospy.Time.now()
        self._rosout.publish(msg)

    def _source(self, logger: str) -> str:
        # a component's records come from its full name; the runner's own notes
        # ("rt_runner") from the node
        return node_like_name(logger) if logger.startswith("/") else self.node_name

    def diagnostics(self, runner: str, status: LiveStatus, aggregate: TimingAggregate) -> None:
        """A timing and health summary on /diagnostics (rqt_runtime_monitor shows it)."""
        from diagnostic_msgs import msg as diagnostic

        array = diagnostic_array(health(runner, status, aggregate), self.node_name, diagnostic)
        array.header.stamp = self._rospy.Time.now()
        self._diagnostics.publish(array)

    def follow_clock(self, box: ClockFeed) -> None:
        """use_sim_time: copy every /clock message (as int64 ns) into ``box``."""
        from rosgraph_msgs.msg import Clock

        def on_clock(msg: Any) -> None:
            ns = msg.clock.secs * 1_000_000_000 + msg.clock.nsecs
            with self._lock:  # the supervisor closes the box when it closes
                if self._clock_box is not None:
                    self._clock_box.write(ns.to_bytes(8, "little", signed=True))

        previous = socket.getdefaulttimeout()
        with self._lock:
            self._clock_box = box
            if self._clock_sub is None:
                self._clock_sub = self._rospy.Subscriber(
                    "/clock", Clock, on_clock, queue_size=1
                )
        # While rospy connects a subscriber to a publisher it sets a process-wide default
        # socket timeout (60 s, rospy/impl/masterslave.py). Every socket made after that
        # is non-blocking, and the supervisor makes its socket pair to the worker right
        # after this call: let the connections to the /clock publishers the master knows
        # of finish, then put the default back
        _wait_for_connections([(self._clock_sub, "/clock", "pub")], CONNECT_TIMEOUT_S)
        socket.setdefaulttimeout(previous)

    def close_run(self) -> None:
        """Publish what is left, then let go of the run's channels (topics stay)."""
        with self._lock:
            self._open = False
            self._drain()
            self._outputs.clear()
            self._inputs.clear()

    # -- the bridge thread -------------------------------------------------------
    def _run(self) -> None:
        while not self._stop.is_set():
            self.doorbell.wait(DRAIN_TIMEOUT_S)
            with self._lock:
                self._drain()

    def _drain(self) -> None:
        for ring, pub, raw, kind in self._outputs:
            while True:
                start, n = ring.pending()
                if n == 0:
                    break
                for slot in range(start, start + n):
                    raw._buff = to_wire(kind, read_record(ring, slot))
                    pub.publish(raw)  # serialized into the connections' queues here
                ring.release(n)

    def shutdown(self) -> None:
        """Leave the ROS graph; rospy cannot start another node in this process."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self.doorbell.close()
        with self._lock:
            self._open = False
            self._outputs.clear()
            self._inputs.clear()
            self._clock_box = None
            topics = [*self._publishers.values(), *self._subscribers.values()]
            self._publishers.clear()
            self._subscribers.clear()
        for _, topic in topics:
            topic.unregister()
        for extra in (self._clock_sub, self._info_pub):
            if extra is not None:
                extra.unregister()
        for face in self._faces.values():
            face.close()
        self._faces.clear()
        if self._introspect_srv is not None:
            self._introspect_srv.shutdown()
        self._clock_sub = self._info_pub = self._introspect_srv = None
        if self._owns_node:
            self._rospy.signal_shutdown("rtcf: the runner shut down")


_FOUR_DOUBLES = struct.Struct("<4d")


_ITERATION_INFO = struct.Struct("<IIQ")  # rtcf_msgs/IterationInfo on the wire


def global_sim_time(store: ParameterStore, runner: str) -> bool | None:
    """The global ``/use_sim_time`` where the runner does not set ``~use_sim_time``.

    None when the runner's private ``~use_sim_time`` is set (it rules) or when
    ``/use_sim_time`` is not set at all. ``store`` is the run's parameter tree, which
    holds the launch file's parameters and the parameter server's.
    """
    if store.has(f"{runner.rstrip('/')}/use_sim_time") or not store.has("/use_sim_time"):
        return None
    value = store.get("/use_sim_time")
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in ("true", "false", "1", "0"):
        return value.strip().lower() in ("true", "1")
    raise RtcfError(f"the global parameter /use_sim_time is {value!r}; use true or false")


def _iteration_info_prefix() -> bytes:
    """The ROS 1 bytes of an iteration_info message before its four doubles.

    Made by serializing a template with genpy and checked by a round trip, so a change
    of the serialization cannot go unnoticed.
    """
    from io import BytesIO

    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=",".join(ITERATION_INFO_LABELS), size=4, stride=4)]
    msg.data = [0.0] * 4
    buf = BytesIO()
    msg.serialize(buf)
    prefix = buf.getvalue()[: -_FOUR_DOUBLES.size]
    probe = Float64MultiArray().deserialize(prefix + _FOUR_DOUBLES.pack(1.0, 2.0, 3.0, 4.0))
    if list(probe.data) != [1.0, 2.0, 3.0, 4.0]:
        raise RtcfError("iteration_info: the ROS 1 template does not round-trip")
    return prefix


def _param_leaves(tree: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """The parameter server's tree as absolute leaf names and values."""
    leaves: list[tuple[str, Any]] = []
    for key, value in tree.items():
        name = f"{prefix}/{key}"
        if isinstance(value, dict) and value:
            leaves.extend(_param_leaves(value, name))
        elif not isinstance(value, dict):
            leaves.append((name, value))
    return leaves


def _clashes(name: str, ours: list[str]) -> bool:
    """Whether the leaf ``name`` is one of ``ours``, above one or below one."""
    for leaf in ours:
        if leaf == name or leaf.startswith(name + "/") or name.startswith(leaf + "/"):
            return True
    return False


def _wait_for_connections(topics: list[tuple[Any, str, str]], timeout: float) -> None:
    """Wait (bounded) until each topic is connected to the peers the master knows of.

    ``topics`` holds (rospy publisher or subscriber, topic, "sub" or "pub": the kind of
    peer to wait for). ROS 1 connects asynchronously, and what is published before a
    subscriber has connected is lost to it.
    """
    if not topics:
        return
    import rosgraph
    import rospy

    try:
        pubs, subs, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    except Exception:  # the master went away: publishing will say so
        return
    me = rospy.get_name()
    expected = []
    for topic, name, peer in topics:
        nodes = dict(subs if peer == "sub" else pubs).get(name, [])
        expected.append((topic, len([n for n in nodes if n != me])))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if all(t.get_num_connections() >= n for t, n in expected):
            return
        time.sleep(0.005)


class _keep_root_logging:
    """rospy's init_node replaces the root logger's handlers (logging.config.fileConfig
    with ROS's python_logging.conf). Put the process's own back beside rospy's log file,
    and keep rospy's chatter in that file, as it is in a plain rospy node."""

    def __enter__(self) -> None:
        root = logging.getLogger()
        self._handlers = list(root.handlers)
        self._level = root.level

    def __exit__(self, *exc: object) -> None:
        root = logging.getLogger()
        theirs = [h for h in root.handlers if h not in self._handlers]
        their_level = root.level
        for handler in self._handlers:
            if handler not in root.handlers:
                root.addHandler(handler)
        root.setLevel(self._level)
        rospy_logger = logging.getLogger("rospy")
        for handler in theirs:
            rospy_logger.addHandler(handler)
        rospy_logger.propagate = False
        if rospy_logger.level == logging.NOTSET:
            rospy_logger.setLevel(their_level)
