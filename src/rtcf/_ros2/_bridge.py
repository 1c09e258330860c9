"""The ROS 2 bridge: mapped ports as ROS 2 topics, in the supervisor process only.

rclpy lives here and never in the worker (../shared/design.md, decisions 1 and 2).
A thread of the supervisor spins a node named after the runner and writes every
message of a mapped input topic into that input's mailbox; another sleeps on the
doorbell that the worker rings and publishes every record that the worker's output
taps pushed. The loop picks up the newest message of a mailbox at the start of its
next iteration. ROS message classes cross as serialized bytes (raw
publish and raw subscriptions); float, int, bool and str become std_msgs Float64,
Int64, Bool and String, and a 1-D float numpy array Float64MultiArray.

QoS of the mapped topics: the runner's ``ros_qos_depth``, ``ros_qos_reliability``
and ``ros_qos_durability``; by default reliable, keep last 10, volatile: what
``ros2 topic pub/echo`` use by default, so the usual tools connect.

``~/iteration_info`` carries one std_msgs/Float64MultiArray per iteration, built
from the timing rows: ``[iteration, stamp (s), calculation duration (s), wake-up
jitter (s)]`` (the original's rtcf_msgs/IterationInfo with standard types; the
layout's labels name the columns). It is serialized here by hand from a template,
so that 2 kHz of it costs the supervisor little.
"""

from __future__ import annotations

import json
import os
import struct
import sys
import threading
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .._core._errors import RtcfError
from .._core._lifecycle import TransitionOutcome
from .._core._log import LogLevel, LogRecord
from .._core._rings import Mailbox, Ring
from .._core._settings import RunnerSettings
from .._core._timing import (
    ITERATION_INFO_BYTES,
    ITERATION_INFO_LABELS,
    TimingAggregate,
    iteration_info_doubles,
)
from .._runtime._doorbell import ClockFeed, Doorbell
from .._runtime._health import diagnostic_array, health
from .._runtime._middleware import import_client, mapped_message_class
from .._runtime._port_channels import MailboxFanOut, MappedPort, read_record
from ._actions import ActionBridge
from ._controller_manager import serve_controller_manager
from ._face import ComponentFace, read_only, ros_logger_name, ros_value
from ._inputs import DirectInputs
from ._liveness import InputEvents, input_qos

if TYPE_CHECKING:
    from .._runtime._supervisor import LiveStatus, WorkerRunner

SPIN_TIMEOUT_S = 0.05  # how often the executor thread looks whether to end
SWITCH_INTERVAL_S = 0.0002  # the supervisor's GIL turn with the timed bridge



def _import_rclpy() -> Any:
    return import_client("rclpy", "ros2", "install ROS 2 Jazzy or pip install 'rtcf[ros2]'")


def message_class(port: MappedPort) -> type:
    """The ROS 2 message class a mapped port is published or subscribed as."""
    return mapped_message_class(port, ros2=True, install="e.g. pip install ros-jazzy-std-msgs")


# Primitive kinds cross as CDR bytes made here, without a message object: the
# encapsulation header (little-endian CDR), then the codec's own little-endian bytes
# (float64, int64, a bool's byte), or a string's length (with its NUL) and bytes. Checked
# against rclpy's serialization by a round trip when a run's channels open.
_CDR_LE = b"\x00\x01\x00\x00"
_U32 = struct.Struct("<I")


def _cdr_encoder(kind: str) -> Callable[[bytes], bytes] | None:
    """The codec's payload as the CDR bytes of its std_msgs message, or None."""
    if kind in ("float", "int"):
        return lambda payload: _CDR_LE + payload
    if kind == "bool":
        return lambda payload: _CDR_LE + payload + b"\x00\x00\x00"
    if kind == "str":
        return lambda payload: _CDR_LE + _U32.pack(len(payload) + 1) + payload + b"\x00"
    return None


def _cdr_decoder(kind: str, cls: type) -> Callable[[bytes], bytes] | None:
    """The CDR bytes of a raw subscription as the codec's payload, or None (a message
    from a big-endian publisher goes through rclpy's deserialization)."""
    from rclpy.serialization import deserialize_message

    def slow(data: bytes) -> bytes:
        return _from_message(kind, deserialize_message(data, cls))

    if kind in ("float", "int"):
        def fixed(data: bytes) -> bytes:
            return data[4:12] if data[:2] == b"\x00\x01" else slow(data)
        return fixed
    if kind == "bool":
        def one(data: bytes) -> bytes:
            return data[4:5] if data[:2] == b"\x00\x01" else slow(data)
        return one
    if kind == "str":
        def text(data: bytes) -> bytes:
            if data[:2] != b"\x00\x01":
                return slow(data)
            n = _U32.unpack_from(data, 4)[0]
            return data[8 : 8 + max(0, n - 1)]
        return text
    return None


def _check_cdr(kind: str, cls: type) -> None:
    """Our CDR bytes and rclpy's agree for this kind (a changed serialization would
    otherwise publish garbage)."""
    from rclpy.serialization import deserialize_message, serialize_message

    samples = {"float": [b"\x00\x00\x00\x00\x00\x00\xf8\x3f"],
               "int": [struct.pack("<q", -2)], "bool": [b"\x01", b"\x00"],
               "str": ["grüße".encode(), b""]}[kind]
    encode, decode = _cdr_encoder(kind), _cdr_decoder(kind, cls)
    assert encode is not None and decode is not None
    for payload in samples:
        ours = encode(payload)
        theirs = serialize_message(_to_message(kind, cls, payload))
        if _from_message(kind, deserialize_message(ours, cls)) != payload or (
            decode(theirs) != payload
        ):
            raise RtcfError(f"the bridge's CDR bytes for {kind} do not round-trip with rclpy's")


def _to_message(kind: str, cls: type, payload: bytes) -> Any:
    if kind == "float":
        return cls(data=struct.unpack("<d", payload)[0])
    if kind == "int":
        return cls(data=struct.unpack("<q", payload)[0])
    if kind == "bool":
        return cls(data=payload != b"\x00")
    if kind == "str":
        return cls(data=payload.decode("utf-8", "replace"))
    if kind == "float_array":
        msg = cls()
        msg.data = list(struct.unpack(f"<{len(payload) // 8}d", payload))
        return msg
    return payload  # already serialized: published raw


def _from_message(kind: str, msg: Any) -> bytes:
    if kind == "float":
        return struct.pack("<d", float(msg.data))
    if kind == "int":
        return struct.pack("<q", int(msg.data))
    if kind == "bool":
        return b"\x01" if msg.data else b"\x00"
    if kind == "str":
        return str(msg.data).encode("utf-8")
    if kind == "float_array":
        data = list(msg.data)
        return struct.pack(f"<{len(data)}d", *data)
    return bytes(msg)  # a raw subscription delivers the serialized bytes


class Ros2Bridge:
    """A ROS 2 node for one runner; its thread moves messages between ROS and channels."""

    def __init__(
        self,
        name: str = "rt_runner",
        namespace: str = "/",
        args: list[str] | None = None,
        *,
        node: Any = None,
    ) -> None:
        """Make a node of the runner's name, or use ``node`` (an rt_runner's own)."""
        rclpy = _import_rclpy()
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        self._rclpy = rclpy
        self._owns_context = node is None
        if node is None:
            self.context = rclpy.Context()
            # never sys.argv (rclpy's default): rtcf launch's name:=value launch arguments
            # would be taken for remap rules (and warned about as deprecated syntax)
            rclpy.init(args=args if args is not None else [], context=self.context,
                       signal_handler_options=_no_signals(rclpy))
            node = Node(name, namespace=namespace, context=self.context)
        else:
            self.context = node.context
        self.node = node
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._rosout = self.node.create_publisher(
            _log_class(), "/rosout", _rosout_qos()
        )
        from diagnostic_msgs.msg import DiagnosticArray

        self._diagnostics = self.node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._lock = threading.Lock()
        self._open = False  # whether a run's channels are there
        self._outputs: list[tuple[Ring, Any, Callable[[bytes], Any]]] = []
        self._subscriptions: list[Any] = []
        self._input_paths: dict[str, str] = {}  # mapped input topic -> direct|executor
        self._publishers: list[Any] = []
        self._faces: dict[str, ComponentFace] = {}  # a node per component
        self._qos: Any = 10
        # mapped inputs with a deadline: DDS's events about their publishers
        self._events = InputEvents(self.node)
        self._qos_deadline = False  # the runner's ros_qos_deadline
        self._info_pub: Any = None
        self._info_prefix = b""
        self._use_sim_time = False
        self._info_offset = 0
        self._introspect_srv: Any = None
        self._controller_manager: Any = None
        self._running = True
        # how outputs reach ROS (docs/performance.md#what-ros-sees): "timed" (CDR bytes
        # made here, the publishing thread at SCHED_FIFO below the loop, short GIL
        # turns) or "plain" (message objects, SCHED_OTHER: the way before, for
        # comparison); RTCF_ROS2_BRIDGE picks
        self.mode = os.environ.get("RTCF_ROS2_BRIDGE", "timed")
        if self.mode not in ("timed", "plain"):
            raise RtcfError(f"RTCF_ROS2_BRIDGE={self.mode!r}: use timed or plain")
        self._cdr_checked: set[str] = set()
        self._publish_priority = 0  # SCHED_FIFO priority of the publishing thread (0: none)
        self._direct: DirectInputs | None = None  # timed: mapped inputs without the executor
        self.publisher_scheduling = "SCHED_OTHER"  # what it got
        self.doorbell = Doorbell.create()
        self._runner: WorkerRunner | None = None
        self._actions = ActionBridge(self.node, self.executor, self._is_active)
        # two threads: one spins the executor (subscriptions, services, parameters),
        # one sleeps on the doorbell and publishes what the worker's outputs pushed
        self._thread = threading.Thread(target=self._spin, name="rtcf-ros2", daemon=True)
        self._thread.start()
        self._publisher = threading.Thread(
            target=self._publish, name="rtcf-ros2-publish", daemon=True
        )
        self._publisher.start()

    def configure(self, settings: RunnerSettings, runner: WorkerRunner) -> None:
        """The runner's QoS for mapped topics, its iteration_info topic and its
        ``~/introspect`` service (std_srvs/Trigger; the answer's message is JSON)."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_srvs.srv import Trigger

        def on_introspect(request: Any, response: Any) -> Any:
            response.success = True
            # with the way each mapped input comes in: "direct" (DirectInputs' thread)
            # or "executor" (rclpy's)
            response.message = json.dumps(
                {**runner.introspect(), "ros2_inputs": dict(self._input_paths)}
            )
            return response

        if self._introspect_srv is None:
            self._introspect_srv = self.node.create_service(
                Trigger, "~/introspect", on_introspect
            )
        runner.transition_listeners.append(self._transitioned)
        self._runner = runner
        if settings.controller_manager and self._controller_manager is None:
            self._controller_manager = serve_controller_manager(
                self.node, runner, settings.controller_manager, self.executor)

        self._qos = QoSProfile(
            depth=settings.ros_qos_depth,
            reliability=ReliabilityPolicy.RELIABLE
            if settings.ros_qos_reliability == "reliable"
            else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL
            if settings.ros_qos_durability == "transient_local"
            else DurabilityPolicy.VOLATILE,
        )
        self._use_sim_time = settings.use_sim_time
        self._qos_deadline = settings.ros_qos_deadline
        self._events.log = runner.log_sink
        if self.mode == "timed":
            self._publish_priority = max(1, settings.priority - 10)
            if self._direct is None:
                priority = self._publish_priority
                self._direct = DirectInputs(self.node, lambda: _fifo_this_thread(priority))
            # a thread waiting for the GIL asks for it after this long (5 ms by default):
            # the publishing thread's wait behind rclpy's executor and the drains
            sys.setswitchinterval(SWITCH_INTERVAL_S)
        # the rows hold CLOCK_MONOTONIC ns (or /clock ns); stamps are ROS time. Taken
        # once, so that stamps are exactly one period apart
        self._info_offset = 0
        if not settings.use_sim_time:
            self._info_offset = self.node.get_clock().now().nanoseconds - time.monotonic_ns()
        if settings.iteration_info and self._info_pub is None:
            from std_msgs.msg import Float64MultiArray

            self._info_prefix = _iteration_info_prefix()
            self._info_pub = self.node.create_publisher(
                Float64MultiArray, "~/iteration_info", 100
            )

    def iteration_info(self, rows: Any) -> None:
        """One message per timing row (called by the supervisor as it drains the rows)."""
        pub = self._info_pub
        if pub is None:
            return
        prefix = self._info_prefix
        data = iteration_info_doubles(rows, self._info_offset)
        for at in range(0, len(data), ITERATION_INFO_BYTES):
            pub.publish(prefix + data[at : at + ITERATION_INFO_BYTES])

    # -- per run -------------------------------------------------------------------
    def open(
        self, ports: list[MappedPort], channels: Mapping[str, Ring | Mailbox | MailboxFanOut]
    ) -> None:
        self._actions.open(ports, channels)
        with self._lock:
            self._open = True
            for port in ports:
                if port.kind == "action":  # served by the ActionBridge
                    continue
                cls = message_class(port)
                channel = channels[port.topic]
                # the timed bridge hands ROS messages over as CDR bytes where it can
                cdr = self.mode == "timed" and _cdr_encoder(port.kind) is not None
                if cdr and port.kind not in self._cdr_checked:
                    _check_cdr(port.kind, cls)
                    self._cdr_checked.add(port.kind)
                if port.direction == "output":
                    assert isinstance(channel, Ring)
                    pub = self.node.create_publisher(cls, port.topic, self._qos)
                    self._publishers.append(pub)
                    kind = port.kind
                    encoder = _cdr_encoder(kind) if cdr else None
                    if encoder is not None:  # bytes: rclpy publishes them as they are
                        convert: Callable[[bytes], Any] = encoder
                    else:
                        def convert(payload: bytes, kind: str = kind, cls: type = cls) -> Any:
                            return _to_message(kind, cls, payload)

                    self._outputs.append((channel, pub, convert))
                else:
                    assert isinstance(channel, Mailbox | MailboxFanOut)
                    decoder = _cdr_decoder(port.kind, cls) if cdr else None
                    raw = port.kind == "ros2" or decoder is not None
                    feed = self._feeder(port, channel, decoder)
                    qos = input_qos(self._qos, port.deadline, self._qos_deadline)
                    # with a deadline: DDS's events about its publishers too (the
                    # executor serves them, wherever the data goes)
                    events = self._events.callbacks(port.topic) if port.deadline > 0 else None
                    if self._direct is not None and raw:  # taken by a thread of its own
                        self._direct.add(cls, port.topic, qos, feed, events)
                        self._input_paths[port.topic] = "direct"
                        continue
                    self._input_paths[port.topic] = "executor"
                    self._subscriptions.append(self.node.create_subscription(
                        cls, port.topic, feed, qos, raw=raw, event_callbacks=events
                    ))

    def _feeder(
        self, port: MappedPort, box: Mailbox | MailboxFanOut,
        decoder: Callable[[bytes], bytes] | None = None,
    ) -> Callable[[Any], None]:
        kind = port.kind

        def on_message(msg: Any) -> None:
            payload = decoder(msg) if decoder is not None else _from_message(kind, msg)
            with self._lock:  # the run may have closed its channels meanwhile
                if self._open and len(payload) <= box.size:
                    box.write(payload)

        return on_message

    def log(self, rec: LogRecord) -> None:
        """Publish a component's log record on /rosout (rqt_console shows it)."""
        from rcl_interfaces.msg import Log

        msg = Log()
        msg.stamp = self.node.get_clock().now().to_msg()
        msg.level = min(max(int(rec.level), 10), 50)  # the numbers of ROS 2's levels
        msg.name = ros_logger_name(rec.logger)
        msg.msg = rec.format()
        msg.function = "update" if rec.iteration >= 0 else ""
        self._rosout.publish(msg)

    def diagnostics(self, runner: str, status: LiveStatus, aggregate: TimingAggregate) -> None:
        """A timing and health summary on /diagnostics (rqt_runtime_monitor shows it)."""
        from diagnostic_msgs import msg as diagnostic

        h = health(runner, status, aggregate)
        for topic, counts in self._events.summary().items():
            h.values += [(f"{topic}: {k.replace('_', ' ')}", str(n)) for k, n in counts.items()]
        array = diagnostic_array(h, self.node.get_fully_qualified_name(), diagnostic)
        array.header.stamp = self.node.get_clock().now().to_msg()
        self._diagnostics.publish(array)

    def follow_clock(self, box: ClockFeed) -> None:
        """use_sim_time: copy every /clock message (as int64 ns) into ``box``."""
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        def on_clock(msg: Any) -> None:
            ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
            box.write(ns.to_bytes(8, "little", signed=True))

        with self._lock:
            self._clock_sub = self.node.create_subscription(
                Clock,
                "/clock",
                on_clock,
                # what rclpy's own time source uses: best effort reaches every publisher
                QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
            )

    def component_loaded(self, info: dict[str, Any], runner: WorkerRunner) -> None:
        """A node of the component's name, with its parameters and logger services."""
        if info.get("launcher"):  # an rt_launcher's node is the component's face
            return
        from rclpy.node import Node

        full = str(info["name"])
        namespace, _, name = full.rpartition("/")
        node = Node(
            name, namespace=namespace or "/", context=self.context, use_global_arguments=False
        )
        level = runner.log_level
        default = int(LogLevel[level.upper()]) if isinstance(level, str) else int(level)
        self._faces[full] = ComponentFace(node, info, runner, default, runner, announced=True)
        self.executor.add_node(node)

    def component_configured(self, info: dict[str, Any], runner: WorkerRunner) -> None:
        """A component loaded unconfigured was configured: its tunables, on its node."""
        face = self._faces.get(str(info["name"]))
        if face is not None:
            face.declare_tunables(info)

    def parameter_set(self, name: str, value: Any) -> None:
        """A component's params.set(): a parameter of the component's node (its private
        ones), else of the runner's node; declared if new."""
        owner = max((f for f in self._faces if name.startswith(f + "/")), key=len, default="")
        node = self._faces[owner].node if owner else self.node
        short = name[len(owner) + 1 :] if owner else name.lstrip("/")
        short = short.replace("/", ".")
        if node.has_parameter(short):
            raise RtcfError(
                f"{node.get_fully_qualified_name()} shows {short!r} read-only, as read at "
                "configure time; set it before the node declares it (in configure, under "
                "a new name) to publish a value"
            )
        node.declare_parameter(short, ros_value(value), read_only(value))

    def _transitioned(self, component: str, outcome: TransitionOutcome) -> None:
        """A component went through a transition: its node's transition events."""
        face = self._faces.get(component)
        if face is not None and face.lifecycle is not None:
            face.lifecycle.publish(outcome)

    def component_unloaded(self, name: str) -> None:
        face = self._faces.pop(name, None)
        if face is not None:
            self.executor.remove_node(face.node)
            face.close()
            face.node.destroy_node()

    def _is_active(self, component: str) -> bool:
        runner = self._runner
        if runner is None:
            return True
        try:
            return runner.lifecycle_state(component) == "active"
        except RtcfError:  # unloaded meanwhile
            return False

    def close_run(self) -> None:
        """Publish what is left, then let go of the run's channels (open goals end)."""
        self._actions.close_run()
        with self._lock:
            self._open = False
            self._drain()
            for pub in self._publishers:
                self.node.destroy_publisher(pub)
            for sub in self._subscriptions:
                self.node.destroy_subscription(sub)
            if self._direct is not None:
                self._direct.clear()
            self._outputs.clear()
            self._publishers.clear()
            self._subscriptions.clear()
            self._input_paths.clear()

    # -- the bridge thread -------------------------------------------------------
    def _spin(self) -> None:
        while self._running:
            try:
                self.executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
            except Exception:  # shutting down
                if not self._running:
                    return
                raise

    def _publish(self) -> None:
        # the lock guards the run's channels only: a service callback may wait in
        # spin_once for the main thread, which needs the lock to close the run
        applied = 0
        while self._running:
            if self._publish_priority != applied:
                applied = self._publish_priority
                self.publisher_scheduling = _fifo_this_thread(applied)
            self.doorbell.wait(SPIN_TIMEOUT_S)
            with self._lock:
                self._drain()
            self._actions.drain()

    def _drain(self) -> None:
        for ring, pub, convert in self._outputs:
            while True:
                start, n = ring.pending()
                if n == 0:
                    break
                for slot in range(start, start + n):
                    pub.publish(convert(read_record(ring, slot)))
                ring.release(n)

    def shutdown(self) -> None:
        self._running = False
        self._thread.join(timeout=5.0)
        self._publisher.join(timeout=5.0)
        if self._direct is not None:
            self._direct.close()
        self.doorbell.close()
        self._actions.shutdown()
        self.executor.shutdown()
        for face in self._faces.values():
            face.close()
            face.node.destroy_node()
        self._faces.clear()
        if self._controller_manager is not None:
            self._controller_manager.close()
        self.node.destroy_node()
        if self._owns_context:
            self._rclpy.shutdown(context=self.context)


def _fifo_this_thread(priority: int) -> str:
    """SCHED_FIFO at ``priority`` for the calling thread (Linux: pid 0 is the thread);
    what it got, for the report."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError) as exc:  # no CAP_SYS_NICE, or not Linux
        return f"SCHED_OTHER (SCHED_FIFO {priority} refused: {exc})"
    return f"SCHED_FIFO {priority}"


_FOUR_DOUBLES = struct.Struct("<4d")  # the template's data, cut off for the prefix


def _iteration_info_prefix() -> bytes:
    """The CDR bytes of an iteration_info message before its four doubles.

    Made by serializing a template and checked by a round trip, so a change of the
    serialization cannot go unnoticed.
    """
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=",".join(ITERATION_INFO_LABELS), size=4, stride=4)]
    msg.data = [0.0] * 4
    prefix = serialize_message(msg)[: -_FOUR_DOUBLES.size]
    probe = deserialize_message(prefix + _FOUR_DOUBLES.pack(1.0, 2.0, 3.0, 4.0), Float64MultiArray)
    if list(probe.data) != [1.0, 2.0, 3.0, 4.0]:
        raise RtcfError("iteration_info: the CDR template does not round-trip")
    return prefix


def _log_class() -> type:
    from rcl_interfaces.msg import Log

    return Log


def _rosout_qos() -> Any:
    """What rcl uses for /rosout: reliable, transient local, depth 1000."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        depth=1000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


def fetch_introspection(runner: str, timeout_s: float = 10.0) -> dict[str, Any]:
    """Ask a running runner (``rtcf launch --middleware ros2`` or rt_runner) what it holds."""
    rclpy = _import_rclpy()

    from rclpy.node import Node
    from std_srvs.srv import Trigger

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=_no_signals(rclpy))
    try:
        node = Node(f"_rtcf_cli_{os.getpid()}", context=context, start_parameter_services=False)
        service = runner.rstrip("/") + "/introspect"
        client = node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=timeout_s):
            raise RtcfError(
                f"no runner answers at {service} within {timeout_s:g} s; is it running "
                "(rtcf launch ... --middleware ros2, or rt_runner) in this ROS_DOMAIN_ID? "
                "name it with --runner"
            )
        from rclpy.executors import SingleThreadedExecutor

        future = client.call_async(Trigger.Request())
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        executor.spin_until_future_complete(future, timeout_sec=timeout_s)
        result = future.result()
        if result is None:
            raise RtcfError(f"{service} did not answer within {timeout_s:g} s")
        data: dict[str, Any] = json.loads(result.message)
        return data
    finally:
        rclpy.try_shutdown(context=context)


def _no_signals(rclpy: Any) -> Any:
    """rclpy must not take over SIGINT: the supervisor stops the loop gracefully."""
    from rclpy.signals import SignalHandlerOptions

    return SignalHandlerOptions.NO
