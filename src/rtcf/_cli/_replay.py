"""``rtcf replay run.mcap [FILE]``: run a launch file on recorded inputs, and record it.

The launch file (by default the one the recording carries) runs on the simulated
clock for as many iterations as the recording has. Every recorded topic that no
component of it produces and some input reads is fed from the recording: in each
iteration, the value recorded in that iteration, if any (as a middleware would have
delivered it). Inputs fed from ROS in the recorded run are fed again; leave a
component out of the launch file and the topics it wrote are fed in its place. The
run is recorded like "rtcf launch --record", so "rtcf diff" compares the two:
with the same components the replay is identical to the recording; with a changed
controller the diff shows what changed.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._core._clock import SimClock
from .._core._errors import ConfigurationError, LaunchError
from .._core._ports import InputPort
from .._core._runner import Runner
from .._launch._files import load_deployment
from .._runtime._codec import codec_for
from .._runtime._mcap import McapRecording
from .._runtime._recording import RecordingDrain, WorkerRecording, recorded_topics, segment_size
from .._runtime._recording_reader import read


def add_parser(sub: Any, add_debug: Callable[[argparse.ArgumentParser], None]) -> None:
    p = sub.add_parser(
        "replay",
        help="run a launch file (the recorded one by default) on a recording's inputs",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("recording", metavar="RECORDING.mcap")
    p.add_argument(
        "target", nargs="*", metavar="TARGET",
        help="FILE or PACKAGE FILE, then name:=value (default: the recorded launch file "
        "and its arguments)",
    )
    p.add_argument(
        "--topics", default=".*", metavar="REGEX",
        help="feed only the recorded topics this full-match regex matches (default: all "
        "that nothing in the launch file produces)",
    )
    p.add_argument(
        "--record", metavar="MCAP",
        help="where the replay is recorded (default: RECORDING.replay.mcap)",
    )
    p.set_defaults(func=cmd_replay, log_level="warning")
    add_debug(p)


class _Recorded:
    """A recording's topics: per topic, its message type and its values by iteration."""

    def __init__(self, path: str) -> None:
        rec = read(path)
        if not rec.metadata:
            raise ConfigurationError(
                f"{path}: no 'rtcf' metadata: is it a recording of rtcf launch --record?"
            )
        self.metadata = rec.metadata
        self.attachments = rec.attachments
        self.types: dict[str, str] = {}
        self.schemas: dict[str, str] = {}  # message type -> its definition, as recorded
        self.values: dict[str, dict[int, Any]] = {}
        for topic, messages in rec.messages.items():
            name = rec.type_name(topic)
            self.types[topic] = name
            if rec.definition(topic):
                self.schemas[name] = rec.definition(topic)
            # CDR primitives decoded here; other messages stay bytes until a port asks
            decode = rec.decoder(topic) if name in _PRIMITIVE_TYPES else None
            self.values[topic] = {
                m.iteration: (name, m.data, decode(m.data) if decode else None)
                for m in messages
            }

    @property
    def iterations(self) -> int:
        return int(json.loads(self.metadata.get("iterations", "0")))


_PRIMITIVE_TYPES = {
    "std_msgs/msg/Float64", "std_msgs/msg/Int64", "std_msgs/msg/Bool", "std_msgs/msg/String",
    "std_msgs/msg/Float64MultiArray",
}


def _value(port_type: type, entry: tuple[str, bytes, Any]) -> Any:
    """The recorded message as the port's value (the type the component reads)."""
    name, raw, decoded = entry
    if name == "std_msgs/msg/Float64MultiArray":
        import numpy as np

        return np.array(list(decoded.data), dtype=np.float64)
    if name in _PRIMITIVE_TYPES and port_type in (float, int, bool, str):
        return port_type(decoded.data)
    codec = codec_for(port_type)  # a ROS message type: its own deserializer, from its bytes
    if codec is None or codec.kind not in ("ros2", "ros1"):
        raise ConfigurationError(f"a recorded {name} cannot feed a port of type "
                                 f"{port_type.__name__}")
    return codec.decode(raw)


class _ReplayFeeder:
    """Feeds one topic's recorded values into the inputs that read it, iteration by
    iteration (the same attributes a worker's feeder has, so a recording taps it)."""

    def __init__(self, topic: str, ports: list[InputPort[Any]], values: dict[int, Any],
                 state: Any) -> None:
        self.topic = topic
        self.type = ports[0].type
        self.slots = [p._slot for p in ports]
        self.values = values
        self.state = state
        self.record: Callable[[Any], None] | None = None

    def __call__(self) -> None:
        i = self.state.iteration
        if i not in self.values:
            return
        value = self.values[i]
        for slot in self.slots:
            slot.value = value
            slot.seq += 1
            slot.iteration = i
        if self.record is not None:
            self.record(value)


def cmd_replay(ns: argparse.Namespace) -> int:
    recorded = _Recorded(ns.recording)
    out = ns.record or str(Path(ns.recording).with_suffix("")) + ".replay.mcap"
    with tempfile.TemporaryDirectory(prefix="rtcf-replay-") as tmp:
        words = list(ns.target)
        if not words:
            launch = [n for n in recorded.attachments if n.startswith("launch/")]
            if not launch:
                raise ConfigurationError(
                    f"{ns.recording} carries no launch file; give one: rtcf replay "
                    f"{ns.recording} FILE"
                )
            path = Path(tmp) / Path(launch[0]).name
            path.write_bytes(recorded.attachments[launch[0]])
            words = [str(path), *json.loads(recorded.metadata.get("launch_arguments", "[]"))]
        deployment = load_deployment(words)
        target = deployment.runner
        runner = Runner(target.settings, clock=SimClock(), parameters=deployment.parameters,
                        name=target.name, log_level="warning")
        try:
            return _replay(ns, recorded, out, deployment, target, runner)
        finally:
            errors = runner.shutdown()
            for err in errors:
                print(f"rtcf: error: {err}", file=sys.stderr)


def _replay(ns: argparse.Namespace, recorded: _Recorded, out: str, deployment: Any,
            target: Any, runner: Runner) -> int:
    for spec in target.components:
        runner.load(spec)
    runner.graph  # noqa: B018 - graph errors now
    if target.settings.mode == "wait_for_trigger":
        runner.activate()
    try:
        pattern = re.compile(ns.topics)
    except re.error as exc:
        raise LaunchError(
            f"--topics {ns.topics!r} is not a valid regular expression: {exc}"
        ) from None
    comps = runner.components
    produced = {p.topic for c in comps.values() for p in c.outputs.values()}
    readers: dict[str, list[InputPort[Any]]] = {}
    for c in comps.values():
        for port in c.inputs.values():
            readers.setdefault(port.topic, []).append(port)
    feeders = []
    for topic, entries in sorted(recorded.values.items()):
        if topic in produced or topic not in readers or not pattern.fullmatch(topic):
            continue
        kind = readers[topic][0].type
        values = {i: _value(kind, e) for i, e in entries.items()}
        feeders.append(_ReplayFeeder(topic, readers[topic], values, runner.state))
    if not feeders and ns.topics != ".*":
        raise LaunchError(f"--topics {ns.topics!r} matches no recorded topic that an input "
                          "reads and nothing produces")
    iterations = recorded.iterations
    if iterations <= 0:
        raise LaunchError(f"{ns.recording}: the recording says it ran no iterations")
    outputs = [p for c in comps.values() for p in c._rtcf_outputs.values()]
    topics = recorded_topics(outputs, [readers[f.topic][0] for f in feeders], ".*")
    from .._ros2._msgdef import message_definition

    def definition(type_name: str) -> str:  # the recorded one, else the installed one
        return recorded.schemas.get(type_name) or message_definition(type_name)

    recording = McapRecording(out, message_definition=definition)
    buf = memoryview(bytearray(segment_size(topics)))
    drain = RecordingDrain(buf, topics)
    recording.begin(topics)
    taps = WorkerRecording(buf, topics, outputs, feeders, runner.state, wait=False)  # type: ignore[arg-type]
    fed = ", ".join(f.topic for f in feeders) or "nothing"
    print(f"rtcf: replaying {iterations} iterations of {ns.recording} with "
          f"{deployment.source}; fed from the recording: {fed}", file=sys.stderr)
    try:
        result = runner.run(
            iterations, feeders=feeders, on_iteration=lambda: drain.drain(recording.write)
        )
    finally:
        counts = taps.counts()
        taps.release()
        drain.drain(recording.write)
        recording.end_run(drain.dropped(), counts)
        drain.close()
        source = Path(deployment.source) if deployment.source else None
        attachments = {}
        if source is not None and source.is_file():
            attachments[f"launch/{source.name}"] = ("application/xml", source.read_bytes())
        recording.finish(
            {
                "replay_of": str(ns.recording),
                "launch_file": str(source or ""),
                "launch_arguments": [w for w in ns.target if ":=" in w],
                "frequency_hz": target.settings.frequency,
                "simulated": True,
                "iterations": runner.state.iteration + 1,
                "order": list(runner.graph.order),
                "fed": [f.topic for f in feeders],
            },
            attachments,
        )
    print(f"rtcf: {recording.summary()}", file=sys.stderr)
    print(f"replayed {result.iterations} iterations; compare: rtcf diff {ns.recording} {out}")
    return 0
