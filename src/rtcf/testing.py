"""Test your own components: run them for N iterations on a simulated clock, in-process.

No worker process, no real time, no middleware: the same runner and executor as
``rtcf launch --sim``, so a test of a controller takes milliseconds and gives the
same values run after run::

    from rtcf.testing import run_components

    def test_p_controller_halves_the_error():
        trace = run_components(
            [PController], iterations=5, frequency=100.0,
            inputs={"/error": [1.0, 0.5, 0.25, 0.125, 0.0625]},
        )
        assert trace.outputs["/command"] == [0.5, 0.25, 0.125, 0.0625, 0.03125]

:func:`run_launch` does the same for a launch file (ROS 1 or ROS 2 XML, as ``rtcf
launch`` takes it). Inputs are fed into topics that no component produces, before
each iteration (as a middleware bridge would); outputs are what every output topic
holds after each iteration (what ``rtcf launch --sim --trace`` writes). A component
that raises fails the call with :class:`rtcf.ComponentError` naming it and the
iteration.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ._core._action_protocol import ActionEndpoint, GoalRecord
from ._core._clock import SimClock
from ._core._component import Component
from ._core._errors import ConfigurationError, RtcfError
from ._core._params import ParameterStore
from ._core._ports import InputPort
from ._core._runner import ComponentSpec, Runner, RunResult
from ._core._settings import RunnerSettings
from ._core._timing import COL_ITERATION, FIXED_COLUMNS, local_ring
from ._core._trace import Trace as _Recorder
from ._launch._files import load_deployment

__all__ = [
    "SILENCE",
    "ActionTrace",
    "Cancel",
    "Goal",
    "GoalRecord",
    "InputValues",
    "SimClock",
    "Trace",
    "run_components",
    "run_launch",
]


class _Silence:
    def __repr__(self) -> str:
        return "rtcf.testing.SILENCE"


SILENCE: Any = _Silence()
"""A value to feed that feeds nothing: in that iteration the input's publisher is
silent (for inputs with a deadline: ``[1.0] * 10 + [SILENCE] * 20 + [2.0]``)."""

InputValues = Any
"""What to feed an input topic: a ``list`` or ``tuple`` is one value per iteration
(the last one stays once it runs out); a callable is called with the iteration and
its time in seconds; :data:`SILENCE` (in a list, or returned) feeds nothing in that
iteration; anything else (a number, a numpy array, a message) is the value
of every iteration. Write ``list(array)`` to feed a numpy array value by value."""

_DEFAULT_FREQUENCY = 1000.0  # Hz, when neither ``frequency`` nor ``settings`` says


@dataclass(frozen=True)
class Goal:
    """A goal sent to an action server: its Goal message, numbered ``id`` (the
    ``goal_id`` the component sees, and the key of ``trace.actions[name].goals``)."""

    message: Any
    id: int


@dataclass(frozen=True)
class Cancel:
    """A request to cancel the goal numbered ``id``."""

    id: int


ActionRequests = Mapping[int, "Goal | Cancel | Sequence[Goal | Cancel]"]
"""What a test sends to one action: iteration -> a Goal, a Cancel, or several (they
reach the component one per iteration, in order, from that iteration on)."""


@dataclass
class ActionTrace:
    """What one action's clients saw: ``goals[id]`` is a :class:`GoalRecord`
    (``accepted``, ``states`` as ``[(iteration, GoalStatus)]``, ``feedback`` as
    ``[(iteration, message)]``, ``status``, ``result``, ``cancel_accepted``)."""

    goals: dict[int, GoalRecord] = field(default_factory=dict)


@dataclass
class Trace:
    """What a run did: per iteration, its number, its time and every output's value.

    ``outputs[topic][k]`` is the value ``topic`` held after iteration ``k`` (None
    before its first write). ``components`` are the instances that ran (full name ->
    component), stopped and cleaned up by now; look inside them as you like.
    ``warnings`` are those ``rtcf launch`` would print (the launch file's, the graph's).
    ``ran[name]`` lists the iterations in which a component's ``update`` ran (read
    from the loop's timing rows: components at a lower rate, or inactive, skip some).
    """

    iterations: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)  # scheduled start: components' self.time
    outputs: dict[str, list[Any]] = field(default_factory=dict)  # topic -> value per iteration
    components: dict[str, Component] = field(default_factory=dict)  # full name -> instance
    ran: dict[str, list[int]] = field(default_factory=dict)  # name -> iterations it ran in
    warnings: list[str] = field(default_factory=list)
    result: RunResult | None = None  # timing counts, order, contained faults, safe stops
    actions: dict[str, ActionTrace] = field(default_factory=dict)  # action name -> its goals

    def last(self, topic: str) -> Any:
        """The value ``topic`` held after the last iteration."""
        return self.outputs[topic][-1]


def run_components(
    components: Iterable[ComponentSpec | type[Component]],
    iterations: int,
    *,
    frequency: float | None = None,
    inputs: Mapping[str, InputValues] | None = None,
    parameters: Mapping[str, Any] | None = None,
    settings: RunnerSettings | None = None,
    actions: Mapping[str, ActionRequests] | None = None,
) -> Trace:
    """Load ``components`` into one runner and run ``iterations`` iterations.

    Each item is a Component class, loaded under its class name in ``/``, or a
    :class:`rtcf.ComponentSpec`: name, namespace, remaps, private parameters,
    ``is_first``, ``policy`` (what a launcher gives). ``parameters`` go into the
    runner's parameter tree first (``{"/gain": 2.0}``). ``frequency`` defaults to
    ``settings.frequency``, or 1000 Hz; ``settings`` are the other runner settings.
    ``actions`` send goals and cancels to action servers, by the action's name and
    iteration (``{"/jtc/follow_joint_trajectory": {0: Goal(msg, id=1), 80: Cancel(1)}}``);
    ``trace.actions[name].goals[1]`` tells what became of each.

    >>> from rtcf_examples import FirstOrderPlant
    >>> plant = ComponentSpec("plant", FirstOrderPlant, params={"time_constant": 0.1})
    >>> trace = run_components([plant], 3, frequency=100.0, inputs={"/u": 1.0})
    >>> [round(y, 3) for y in trace.outputs["/y"]]
    [0.1, 0.19, 0.271]
    """
    specs = [_spec(c) for c in components]
    if frequency is None:
        frequency = settings.frequency if settings is not None else _DEFAULT_FREQUENCY
    settings = dataclasses.replace(settings or RunnerSettings(), frequency=frequency)
    store = ParameterStore()
    for key, value in (parameters or {}).items():
        store.set(key, value)
    runner = Runner(settings, clock=SimClock(), parameters=store, name="rt_runner")
    return _run(runner, specs, iterations, inputs or {}, [], actions or {})


def run_launch(
    target: str | Sequence[str],
    iterations: int | None = None,
    *,
    duration: float | None = None,
    args: Mapping[str, object] | None = None,
    inputs: Mapping[str, InputValues] | None = None,
    actions: Mapping[str, ActionRequests] | None = None,
) -> Trace:
    """Run the runner of a launch file for ``iterations`` (or ``duration`` seconds).

    ``target`` is what ``rtcf launch`` takes: a path, or ``"PACKAGE FILE"`` /
    ``["PACKAGE", "FILE"]``, ROS 1 or ROS 2 launch XML. ``args`` are the launch
    arguments (``{"gain": 2.0}`` is ``gain:=2.0``). The file's runner settings apply,
    on the simulated clock; a ``wait_for_trigger`` runner starts at once, as under
    ``rtcf launch`` with no middleware. ``actions`` as for :func:`run_components`.

    >>> trace = run_launch("rtcf_examples sum_test.launch", 2, inputs={"/rtcf/ros/in": 1.0})
    >>> trace.outputs["/rtcf/ros/out"]
    [3.0, 3.0]
    """
    if (iterations is None) == (duration is None):
        raise ConfigurationError("give either iterations or duration (seconds)")
    words = target.split() if isinstance(target, str) else list(target)
    words += [f"{k}:={v}" for k, v in (args or {}).items()]
    deployment = load_deployment(words)
    runner_deployment = deployment.runner
    settings = runner_deployment.settings
    if duration is not None:
        iterations = max(1, round(duration * settings.frequency))  # as rtcf launch --duration
    runner = Runner(
        settings,
        clock=SimClock(),
        parameters=deployment.parameters,
        name=runner_deployment.name,
    )
    assert iterations is not None
    try:
        return _run(
            runner, runner_deployment.components, iterations, inputs or {}, deployment.warnings,
            actions or {},
        )
    except RtcfError as exc:
        if exc.file is None:
            exc.file = deployment.source  # a graph error belongs to the whole file
        raise


def _spec(item: object) -> ComponentSpec:
    if isinstance(item, ComponentSpec):
        return item
    if isinstance(item, type) and issubclass(item, Component):
        return ComponentSpec(item.__name__, item)
    if isinstance(item, Component):
        raise TypeError(
            f"give the class {type(item).__name__}, or a ComponentSpec, not an instance: "
            "the runner constructs each component (name, parameters and ports come "
            "before __init__); set what varies through parameters"
        )
    raise TypeError(f"{item!r} is neither an rtcf.Component class nor a ComponentSpec")


def _run(
    runner: Runner,
    specs: Sequence[ComponentSpec],
    iterations: int,
    inputs: Mapping[str, InputValues],
    warnings: Sequence[str],
    actions: Mapping[str, ActionRequests],
) -> Trace:
    if iterations < 0:
        raise ValueError(f"iterations must be 0 or more, not {iterations}")
    trace = Trace(warnings=list(warnings))
    try:
        for spec in specs:
            runner.load(spec)
        trace.components = components = runner.components
        trace.warnings += runner.graph.warnings
        feeders = _feeders(components, inputs, runner)
        feeders += _action_clients(components, actions, runner, trace)
        if runner.settings.mode == "wait_for_trigger":
            runner.activate()  # nothing else would trigger it here
        recorder: list[_Recorder] = []
        state = runner.state
        schedule = runner.schedule
        # the columns of components (not those of a lane's handovers)
        ran: dict[str, list[int]] = {name: [] for name in schedule}
        trace.ran = ran
        ran_columns = list(enumerate(ran.values(), start=FIXED_COLUMNS))
        timing = local_ring(len(schedule), 16)

        def record() -> None:  # after each iteration, outside its measured time
            if not recorder:  # created once the runner has wired the slots
                recorder.append(_Recorder(components, state, runner.visible_slots()))
            recorder[0].sample()
            while (row := timing.pop()) is not None:
                words = memoryview(row).cast("q")
                for column, ran_in in ran_columns:
                    if words[column] >= 0:  # -1: skipped (another phase, or inactive)
                        ran_in.append(words[COL_ITERATION])
                words.release()

        trace.result = runner.run(
            iterations, on_iteration=record, feeders=feeders, timing_ring=timing
        )
    finally:
        errors = runner.shutdown()
    if errors:
        raise errors[0]
    trace.ran = {n: r for n, r in trace.ran.items() if not n.startswith("@")}  # not handovers
    topics = sorted({p.topic for c in components.values() for p in c.outputs.values()})
    trace.outputs = {topic: [] for topic in topics}
    if recorder:
        columns = [trace.outputs[t] for t in recorder[0].topics]
        for row in recorder[0].rows:
            trace.iterations.append(row[0])
            trace.times.append(row[1] * 1e-9)
            for column, value in zip(columns, row[2:], strict=True):
                if len(column) < len(trace.iterations):  # a topic two outputs write: once
                    column.append(value)
    return trace


def _feeders(
    components: Mapping[str, Component], inputs: Mapping[str, InputValues], runner: Runner
) -> list[Callable[[], None]]:
    """One feeder per input topic: the ports that read it, checked to be unproduced."""
    produced = {p.topic: p for c in components.values() for p in c.outputs.values()}
    readers: dict[str, list[InputPort[Any]]] = {}
    for c in components.values():
        for port in c.inputs.values():
            readers.setdefault(port.topic, []).append(port)
    for topic in inputs:
        if topic in produced:
            raise ConfigurationError(
                f"input {topic!r} is produced by {produced[topic].component}: feed only "
                "topics that no component produces"
            )
    unread = [t for t in inputs if t not in readers]
    if unread:
        read = ", ".join(sorted(t for t in readers if t not in produced)) or "nothing"
        raise ConfigurationError(
            f"no component reads {', '.join(unread)}; the inputs you can feed: {read}"
        )
    return [_feeder(readers[t], _values(v), runner) for t, v in inputs.items()]


def _action_clients(
    components: Mapping[str, Component],
    actions: Mapping[str, ActionRequests],
    runner: Runner,
    trace: Trace,
) -> list[Callable[[], None]]:
    """Per action: a feeder of its requests input (one request per iteration, once
    the server took the last), and a tap on its events output (every event)."""
    servers = {s.name: s for c in components.values() for s in c._rtcf_actions.values()}
    feeders = []
    state = runner.state
    for name, requests in actions.items():
        server = servers.get(name)
        if server is None:
            served = ", ".join(sorted(servers)) or "none"
            raise ConfigurationError(
                f"no component serves the action {name!r}; the actions served: {served}"
            )
        endpoint = ActionEndpoint(name)
        trace.actions[name] = ActionTrace(endpoint.goals)
        feeders.append(_action_feeder(server._requests, endpoint, requests, runner))

        def tap(event: Any, _endpoint: ActionEndpoint = endpoint) -> None:
            _endpoint.receive(event, state.iteration)

        server._events._tap = tap
    return feeders


def _action_feeder(
    port: InputPort[Any], endpoint: ActionEndpoint, requests: ActionRequests, runner: Runner
) -> Callable[[], None]:
    state = runner.state
    waiting: list[Any] = []
    by_iteration = {
        i: list(r) if isinstance(r, (list, tuple)) else [r] for i, r in requests.items()
    }

    def feed() -> None:
        waiting.extend(by_iteration.get(state.iteration, ()))
        if waiting and not port.has_new_data:  # the server took the last one
            item = waiting.pop(0)
            if isinstance(item, Goal):
                req = endpoint.goal_request(item.message, item.id)
            elif isinstance(item, Cancel):
                req = endpoint.cancel_request(item.id)
            else:
                raise ConfigurationError(
                    f"action {endpoint.name!r}: {item!r} is neither a testing.Goal nor a "
                    "testing.Cancel"
                )
            slot = port._slot
            slot.value = req
            slot.seq += 1

    return feed


def _values(spec: InputValues) -> Callable[[int, float], Any]:
    if isinstance(spec, (list, tuple)):
        seq = list(spec)
        if not seq:
            raise ConfigurationError("an input sequence needs at least one value")
        return lambda i, t: seq[min(i, len(seq) - 1)]
    if callable(spec):
        return spec
    return lambda i, t: spec


def _feeder(
    ports: list[InputPort[Any]], values: Callable[[int, float], Any], runner: Runner
) -> Callable[[], None]:
    state = runner.state

    def feed() -> None:  # before the components, at the start of each iteration
        value = values(state.iteration, state.time_ns * 1e-9)
        if value is SILENCE:
            return
        for port in ports:  # as a middleware bridge feeds an input nothing here produces
            slot = port._slot
            slot.value = value
            slot.seq += 1

    return feed
