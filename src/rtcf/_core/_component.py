"""The component: the smallest reusable unit, with a lifecycle and typed ports.

Write one by subclassing :class:`Component` and overriding the hooks you need::

    class Gain(rtcf.Component):
        def configure(self):
            self.inp = self.add_input("in", float)
            self.out = self.add_output("out", float)
            self.k = self.params.get("~gain", 2.0)

        def update(self):
            x = self.inp.read()
            if x is not None:
                self.out.write(self.k * x)

Hooks (all optional): ``configure`` (add ports, read parameters), ``start`` (just
before the loop first runs it), ``update`` (once per iteration, real-time),
``stop`` and ``cleanup``. A hook that returns False or raises has failed.
A component whose ``update`` is not overridden costs nothing in the loop.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

from ._action_protocol import ActionEvent, ActionRequest
from ._actions import ActionServer, check_action
from ._command_limits import CommandGuard, JointLimits, declare_command_input
from ._faults import deadline_ns
from ._interface_ports import (
    COMMAND,
    STATE,
    HardwareKeys,
    InterfacePorts,
    add_port,
    declare_interfaces,
)
from ._lane_names import MAIN_LANE
from ._log import ComponentLogger, LogRing, RecordSink
from ._loop_state import LoopState
from ._names import Resolver, join
from ._params import ParameterStore, Params
from ._ports import InputPort, OutputPort

T = TypeVar("T")


class Component:
    """Base class of real-time components (the original's ``RTT::TaskContext``)."""

    name: str
    namespace: str
    params: Params
    log: ComponentLogger
    # the runner's wiring, kept apart from user attributes by the prefix
    _rtcf_state: LoopState
    _rtcf_resolver: Resolver
    _rtcf_inputs: dict[str, InputPort[Any]]
    _rtcf_outputs: dict[str, OutputPort[Any]]
    _rtcf_claims: set[str]  # names of the outputs declared claim=True
    _rtcf_actions: dict[str, ActionServer]
    _rtcf_guards: dict[str, CommandGuard]  # command inputs' checks, by port name
    # ports that are hardware interfaces (their keys), and those bound to the run's
    # hardware (no topics: kept out of _rtcf_inputs/_rtcf_outputs)
    _rtcf_interfaces: dict[str, InterfacePorts]
    _rtcf_bound: dict[str, Any]
    _rtcf_hardware: HardwareKeys | None = None  # the run's hardware (None: none)
    _rtcf_configured: bool
    _rtcf_every: int = 1  # runs every this many iterations (its launcher's rate or every)
    _rtcf_lane: str = MAIN_LANE  # the lane (worker process) it runs in
    # while configure runs again (lifecycle): the port names declared so far
    _rtcf_redeclared: set[str] | None = None

    def __init__(self) -> None:
        # Constructed by a runner, the context is attached before __init__ runs; a
        # component constructed directly (in a unit test) gets a context of its own.
        if not hasattr(self, "_rtcf_state"):
            _attach(
                self,
                name=type(self).__name__,
                namespace="/",
                resolver=Resolver("/", type(self).__name__),
                store=ParameterStore(),
                ring=LogRing(256),
                state=LoopState(),
            )

    # -- hooks --------------------------------------------------------------
    def configure(self) -> bool | None:
        """Add ports and read parameters. Runs at load (or at the first ``configure`` if
        loaded unconfigured), again at ``configure`` after ``cleanup`` (same ports)."""
        return None

    def start(self) -> bool | None:
        """Prepare to run; called before the first ``update`` after loading."""
        return None

    def update(self) -> None:
        """One iteration of work. Real-time: no blocking calls, no I/O."""

    def stop(self) -> None:
        """The loop will no longer call ``update`` (the component is unloaded or the
        runner stops)."""

    def cleanup(self) -> None:
        """Release what ``configure`` acquired."""

    def safe_stop(self) -> bool | None:
        """Bring what this component drives to a safe state (zero torque, hold position).

        Runs in the worker whenever the loop ends for any reason other than a normal
        stop: a component raised, a watchdog fired, the supervisor died or was
        stopped with a signal, the worker got SIGTERM or SIGINT; and when a fault
        policy takes this component out of the schedule. Active components run it
        last in the execution order first, each on its own (one that raises does
        not keep the others from running); ``stop`` and ``cleanup`` follow as usual.
        Keep it short and self-contained: it may run after another component failed.
        """
        return None

    # -- ports ----------------------------------------------------------------
    def add_input(
        self, name: str, type_: type[T], *, deadline: float | None = None
    ) -> InputPort[T]:
        """Declare an input port (in ``configure``); its topic is ``name`` resolved.

        ``deadline`` (seconds): when the newest value is older than this, the port's
        ``status`` is ``FlowStatus.EXPIRED`` and the component's ``on_deadline`` policy
        applies (docs/runner.md, "Input deadlines"); a launch file's ``deadline/NAME``
        overrides it.
        """
        port: InputPort[T] = InputPort(self.full_name, name, type_)
        if deadline is not None:
            where = f"input {name!r}"
            port._deadline_ns = deadline_ns(deadline, where)
        # configured again: the port of the first configure, with its deadline (a launch
        # file's may have replaced the component's)
        return add_port(self, port, self._rtcf_inputs)

    def add_output(self, name: str, type_: type[T], *, claim: bool = False) -> OutputPort[T]:
        """Declare an output port (in ``configure``); its topic is ``name`` resolved.

        ``claim=True`` makes it a claimed command (ros2_control's command interface):
        several components may write its topic through claimed outputs, at most one of
        them active at a time (docs/controllers.md, "Claimed commands and switching").
        """
        port: OutputPort[T] = OutputPort(self.full_name, name, type_, self._rtcf_state)
        port = add_port(self, port, self._rtcf_outputs)
        if claim:
            self._rtcf_claims.add(name)
        return port

    def add_command_input(
        self, name: str, interface: str, joints: Sequence[str],
        limits: Mapping[str, JointLimits] | Sequence[JointLimits] | None = None, *,
        deadline: float | None = None,
    ) -> InputPort[Any]:
        """Declare a hardware's command input (in ``configure``): a float64 array per
        command, a value per joint, of ros2_control's ``interface``. A new command is
        checked before each ``update``: a non-finite one is never passed on, one outside
        ``limits`` is clamped (docs/hardware-limits.md)."""
        return declare_command_input(self, name, interface, joints, limits, deadline)

    def add_state_interfaces(
        self, name: str, keys: Sequence[str], *, deadline: float | None = None
    ) -> InputPort[Any]:
        """Declare an input of hardware state interfaces (in ``configure``): a float64
        array, a value per key (``"joint1/position"``) in the order of ``keys``; an empty
        key is a place with no interface (NaN). When the run has hardware (a robot
        description), the values come from it before each ``update``, with no topic and
        no remap; without, it is the input ``name`` of ``np.ndarray``
        (docs/hardware.md#controllers-and-interfaces)."""
        return declare_interfaces(self, name, STATE, keys, deadline)

    def add_command_interfaces(self, name: str, keys: Sequence[str]) -> OutputPort[Any]:
        """Declare an output of hardware command interfaces (in ``configure``): write a
        float64 array, a value per key in the order of ``keys``. When the run has
        hardware, what ``update`` wrote goes to those interfaces after it (checked
        against the description's limits), and activation claims the keys; without, it
        is the claimed output ``name`` of ``np.ndarray``."""
        return declare_interfaces(self, name, COMMAND, keys)

    @property
    def hardware(self) -> HardwareKeys | None:
        """The run's hardware interfaces (``state_keys``, ``command_keys``), or None when
        the run has no hardware."""
        return self._rtcf_hardware

    def add_action_server(
        self, name: str, action_type: type, *, max_goals: int = 1
    ) -> ActionServer:
        """Serve the action ``name`` (in ``configure``): goals and cancels come in through
        ``request()``, feedback and results go out; at most ``max_goals`` goals are open at
        once. ``action_type`` is a ROS 2 action class, or any class with ``Goal``,
        ``Result`` and ``Feedback``. Two ports carry it: ``<name>/_action/requests`` and
        ``<name>/_action/events``."""
        check_action(self.full_name, name, action_type, max_goals)
        requests = self.add_input(f"{name}/_action/requests", ActionRequest)
        events = self.add_output(f"{name}/_action/events", ActionEvent)
        old = self._rtcf_actions.get(name)
        if old is not None and self._rtcf_redeclared is not None:
            return old  # configure() again: the same server, its table as it is
        server = ActionServer(
            self.full_name, self._rtcf_resolver.resolve(name), action_type, requests, events,
            max_goals, self._rtcf_state,
        )
        self._rtcf_actions[name] = server
        return server

    @property
    def inputs(self) -> dict[str, InputPort[Any]]:
        """The input ports by name (a copy)."""
        return dict(self._rtcf_inputs)

    @property
    def outputs(self) -> dict[str, OutputPort[Any]]:
        """The output ports by name (a copy)."""
        return dict(self._rtcf_outputs)

    # -- loop information (the original's getTime/getIteration/getFrequency) --
    @property
    def full_name(self) -> str:
        return join(self.namespace, self.name)

    @property
    def iteration(self) -> int:
        """Index of the current iteration, from 0 (-1 before the loop first ran)."""
        return self._rtcf_state.iteration

    @property
    def time(self) -> float:
        """Scheduled start of the current iteration in seconds since the loop started."""
        return self._rtcf_state.time_ns * 1e-9

    @property
    def time_ns(self) -> int:
        return self._rtcf_state.time_ns

    @property
    def stamp_ns(self) -> int:
        """ROS time of this iteration's scheduled start, in ns since the epoch: wall
        time, or /clock time under ``use_sim_time`` (the original's ``getTime()``); for
        message headers. Under ``--sim`` it counts from 0, like ``time``."""
        return self._rtcf_state.stamp_ns

    def stamp_to(self, stamp: Any) -> Any:
        """Write this iteration's ROS time into a header stamp and return it: ROS 2's
        ``builtin_interfaces/Time`` (``sec``, ``nanosec``) or ROS 1's ``genpy.Time``
        (``secs``, ``nsecs``), e.g. ``self.stamp_to(msg.header.stamp)``."""
        sec, nsec = divmod(self._rtcf_state.stamp_ns, 1_000_000_000)
        if hasattr(stamp, "nanosec"):
            stamp.sec, stamp.nanosec = sec, nsec
        else:
            stamp.secs, stamp.nsecs = sec, nsec
        return stamp

    @property
    def frequency(self) -> float:
        """How often this component runs, in Hz: the loop's frequency, divided by its
        ``every`` when its launcher gives it a slower rate."""
        return self._rtcf_state.frequency / self._rtcf_every

    @property
    def period(self) -> float:
        """The time between two runs of this component in seconds: the loop's period
        times ``every`` (what a controller integrates or differentiates over)."""
        return self._rtcf_state.period_ns * self._rtcf_every * 1e-9

    @property
    def every(self) -> int:
        """It runs every this many iterations of the loop (1: every iteration)."""
        return self._rtcf_every

    @property
    def lane_name(self) -> str:
        """The lane it runs in (its launcher's ``lane``; ``"main"``: the runner's own).
        Not ``lane``: a component's own attribute of that name (a lane keeper's) stays
        its own."""
        return self._rtcf_lane

    @property
    def on_let(self) -> bool:
        """Whether it runs on logical execution time: in a lane other than main, every
        N > 1 iterations. Released in iteration ``r``, it then reads its inputs as
        iteration ``r - 1`` left them, and what it writes appears at the start of
        iteration ``r + N`` (docs/runner.md#lanes). Known in ``configure``."""
        return self._rtcf_lane != MAIN_LANE and self._rtcf_every > 1

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.full_name}>"


def _attach(
    component: Component,
    *,
    name: str,
    namespace: str,
    resolver: Resolver,
    store: ParameterStore,
    ring: RecordSink,
    state: LoopState,
    emit: Callable[[int, str, str, int, int], None] | None = None,
    every: int = 1,
    hardware: HardwareKeys | None = None,
    lane: str = MAIN_LANE,
) -> None:
    """Give ``component`` its identity and its access to the runner (before __init__)."""
    component.name = name
    component.namespace = namespace
    full = join(namespace, name)
    component.params = Params(store, resolver, full, lambda: state.running)
    component.log = ComponentLogger(full, ring, state, emit=emit)
    component._rtcf_state = state
    component._rtcf_resolver = resolver
    component._rtcf_inputs = {}
    component._rtcf_outputs = {}
    component._rtcf_claims = set()
    component._rtcf_actions = {}
    component._rtcf_guards = {}
    component._rtcf_interfaces = {}
    component._rtcf_bound = {}
    component._rtcf_hardware = hardware
    component._rtcf_configured = False
    component._rtcf_every = every
    component._rtcf_lane = lane


def overrides(component: Component, hook: str) -> bool:
    """Whether ``component``'s class overrides ``hook`` of the base class."""
    return getattr(type(component), hook) is not getattr(Component, hook)
