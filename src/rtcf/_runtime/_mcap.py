"""A recording as a standard MCAP file: ROS 2 schemas (``ros2msg``), CDR messages.

The supervisor writes what the worker's recording rings hold with the ``mcap`` and
``mcap-ros2-support`` packages (``pip install 'rtcf[record]'``): primitives as
std_msgs (Float64, Int64, Bool, String), float arrays as std_msgs/Float64MultiArray,
ROS 2 messages as themselves (CDR, their definition from the installed ``.msg``
files), ROS 1 messages as themselves (``ros1msg`` schemas from genpy, ``ros1``
encoding: MCAP holds both; Foxglove reads either). Each message's
log and publish time is the iteration's stamp (ROS time of its scheduled start: wall
time, /clock time, or from 0 under ``--sim``) and its sequence number the iteration.
The file also carries what reproduces the run: the launch file, the runner's
settings, the order and timing.json as attachments, and a metadata record ``rtcf``
with the counts, including every record a full ring had to drop.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from .._core._errors import ConfigurationError
from .._core._message_types import message_class, std_type_name
from .._core._timing import COL_CALC, COL_ITERATION, COL_JITTER, COL_SCHEDULED
from ._codec import Codec, codec_for
from ._recording import Record, RecordedTopic

_MULTI_ARRAY = """std_msgs/MultiArrayLayout layout
float64[] data
================================================================================
MSG: std_msgs/MultiArrayLayout
std_msgs/MultiArrayDimension[] dim
uint32 data_offset
================================================================================
MSG: std_msgs/MultiArrayDimension
string label
uint32 size
uint32 stride
"""

# a port's codec kind -> the ROS 2 message it is recorded as, and its definition
_DEFINITIONS = {
    "float": "float64 data\n",
    "int": "int64 data\n",
    "bool": "bool data\n",
    "str": "string data\n",
    "float_array": _MULTI_ARRAY,
}
# a primitive kind's schema: its std_msgs type and that type's definition
PRIMITIVES: dict[str, tuple[str, str]] = {
    kind: (std_type_name(kind), text) for kind, text in _DEFINITIONS.items()
}

RECORD_HINT = "install the recording extra: pip install 'rtcf[record]'"


def _with_lists(value: Any) -> Any:
    """A ROS 2 message as plain values (dicts, lists), every numpy array a list."""
    fields = getattr(value, "get_fields_and_field_types", None)
    if fields is not None:
        return {name: _with_lists(getattr(value, name)) for name in fields()}
    if isinstance(value, list):
        return [_with_lists(v) for v in value]
    tolist = getattr(value, "tolist", None)  # a numpy array
    return tolist() if tolist is not None else value


def _primitive_message(kind: str, value: Any) -> Any:
    if kind == "float_array":
        data = [float(x) for x in value]
        n = len(data)
        return {
            "layout": {"dim": [{"label": "", "size": n, "stride": n}], "data_offset": 0},
            "data": data,
        }
    return {"data": value}


class McapRecording:
    """Writes one run's records into ``path`` (opened at the first run)."""

    def __init__(
        self,
        path: str,
        pattern: str = ".*",
        *,
        message_definition: Callable[[str], str] | None = None,
    ) -> None:
        try:
            from mcap_ros2.writer import Writer
        except ImportError:
            raise ConfigurationError(
                f"--record {path}: the mcap packages are not installed; {RECORD_HINT}"
            ) from None
        self.path = path
        self.pattern = pattern
        self._definition = message_definition
        class _Writer(Writer):
            """mcap-ros2-support's writer, plus ROS 1 messages as they are serialized
            (``ros1msg`` schemas, ``ros1`` encoding), through its underlying writer."""

            def register_raw_schema(self, name: str, encoding: str, text: str) -> int:
                return int(self._writer.register_schema(name, encoding, text.encode()))

            def register_raw_channel(self, topic: str, encoding: str, schema_id: int) -> int:
                return int(self._writer.register_channel(
                    topic=topic, message_encoding=encoding, schema_id=schema_id
                ))

            def write_raw(self, channel_id: int, data: bytes, stamp: int, sequence: int) -> None:
                self._writer.add_message(
                    channel_id=channel_id, log_time=stamp, publish_time=stamp,
                    sequence=sequence, data=data,
                )

        self._writer_class = _Writer
        self._writer: Any = None
        self._file: Any = None
        self._channels: dict[str, tuple[Any, Codec, str]] = {}  # topic -> schema, codec, kind
        self._as_lists: set[str] = set()  # ROS 2 topics written as plain values
        # the runner's iteration_info, one message per timing row (rtcf evaluate reads it)
        self.timing_topic: str | None = None
        self._timing_schema: Any = None
        self.messages: dict[str, int] = {}
        self.dropped: dict[str, int] = {}
        self.oversize: dict[str, int] = {}

    def begin(self, topics: list[RecordedTopic]) -> None:
        """Register the schemas and channels of a run's recorded topics."""
        if self._writer is None:
            try:
                self._file = open(self.path, "wb")
            except OSError as exc:
                raise ConfigurationError(
                    f"--record {self.path}: cannot write it: {exc.strerror}"
                ) from None
            self._writer = self._writer_class(self._file)
        for t in topics:
            if t.topic in self._channels:
                continue
            name, text = self._schema(t)
            if t.kind != "ros1":
                schema = self._writer.register_msgdef(name, text)
            else:  # genpy's serialization (no padding): written as it is
                schema_id = self._writer.register_raw_schema(name, "ros1msg", text)
                schema = self._writer.register_raw_channel(t.topic, "ros1", schema_id)
            codec = codec_of(t)
            self._channels[t.topic] = (schema, codec, t.kind)
            self.messages.setdefault(t.topic, 0)

    def _schema(self, t: RecordedTopic) -> tuple[str, str]:
        if t.kind in PRIMITIVES:
            return PRIMITIVES[t.kind]
        if t.kind == "ros2":
            if self._definition is None:
                raise ConfigurationError(
                    f"{t.topic} ({t.type_name}) is recorded, but no ROS 2 message "
                    "definitions are at hand"
                )
            return t.type_name, self._definition(t.type_name)
        if t.kind == "ros1":  # genpy keeps the full definition with the class
            return t.type_name, str(_message_class(t)._full_text)  # type: ignore[attr-defined]
        raise ConfigurationError(f"{t.topic}: values of kind {t.kind} cannot be recorded")

    def write(self, record: Record) -> None:
        schema, codec, kind = self._channels[record.topic]
        stamp = max(0, record.stamp_ns)
        if kind == "ros1":
            self._writer.write_raw(schema, record.payload, stamp, record.iteration & 0xFFFFFFFF)
            self.messages[record.topic] += 1
            return
        # ROS 2 messages are decoded and encoded again, not copied: rclpy's CDR leaves
        # its alignment padding uninitialized, so equal messages would differ in bytes
        value = codec.decode(record.payload)
        message = value if kind == "ros2" else _primitive_message(kind, value)
        if record.topic in self._as_lists:
            message = _with_lists(message)
        sequence = record.iteration & 0xFFFFFFFF
        try:
            self._writer.write_message(
                record.topic, schema, message,
                log_time=stamp, publish_time=stamp, sequence=sequence,
            )
        except ValueError:
            # mcap_ros2 takes arrays as lists; rclpy gives fixed-size ones (Odometry's
            # covariance) as numpy arrays: such a topic's messages go as plain values
            if kind != "ros2" or record.topic in self._as_lists:
                raise
            self._as_lists.add(record.topic)
            self._writer.write_message(
                record.topic, schema, _with_lists(message),
                log_time=stamp, publish_time=stamp, sequence=sequence,
            )
        self.messages[record.topic] += 1

    def timing_rows(self, rows: Any, offset_ns: int) -> None:
        """The loop's timing rows as ``iteration_info`` (``[iteration, stamp s,
        calculation s, wake-up jitter s]``, as ROS 2's ``~/iteration_info``), stamped
        with the scheduled start plus ``offset_ns`` (ROS time)."""
        if self.timing_topic is None or self._writer is None:
            return
        if self._timing_schema is None:
            self._timing_schema = self._writer.register_msgdef(*PRIMITIVES["float_array"])
            self.messages.setdefault(self.timing_topic, 0)
        layout = {
            "dim": [{"label": "iteration,stamp,calculation,jitter", "size": 4, "stride": 4}],
            "data_offset": 0,
        }
        write = self._writer.write_message
        for it, scheduled, jitter, calc in rows[
            :, [COL_ITERATION, COL_SCHEDULED, COL_JITTER, COL_CALC]
        ].tolist():
            stamp = max(0, scheduled + offset_ns)
            write(
                self.timing_topic, self._timing_schema,
                {"layout": layout, "data": [float(it), stamp * 1e-9, calc * 1e-9, jitter * 1e-9]},
                log_time=stamp, publish_time=stamp, sequence=it & 0xFFFFFFFF,
            )
        self.messages[self.timing_topic] += len(rows)

    def end_run(self, dropped: dict[str, int], counts: dict[str, dict[str, int]]) -> None:
        """What a run's rings had to drop, and values too large for a record."""
        for topic, n in dropped.items():
            self.dropped[topic] = self.dropped.get(topic, 0) + n
        for topic, c in counts.items():
            if c.get("oversize"):
                self.oversize[topic] = self.oversize.get(topic, 0) + c["oversize"]

    def finish(
        self, metadata: dict[str, Any], attachments: dict[str, tuple[str, bytes]]
    ) -> None:
        """Write the metadata and the attachments (name -> media type, bytes); close."""
        if self._writer is None:
            return
        meta = {k: v if isinstance(v, str) else json.dumps(v) for k, v in metadata.items()}
        meta["messages"] = json.dumps(self.messages)
        if self.timing_topic is not None:
            meta["timing_topic"] = self.timing_topic
        meta["dropped"] = json.dumps(self.dropped)
        meta["oversize"] = json.dumps(self.oversize)
        self._writer.add_metadata("rtcf", meta)
        for name, (media_type, data) in attachments.items():
            self._writer.add_attachment(0, 0, name, media_type, data)
        self._writer.finish()
        self._file.close()
        self._writer = None

    def summary(self) -> str:
        total = sum(self.messages.values())
        lost = sum(self.dropped.values()) + sum(self.oversize.values())
        line = (
            f"recorded {total} messages on {len(self.messages)} topics into {self.path}; "
            f"dropped: {lost}"
        )
        if lost:
            parts = [f"{t} {n} (ring full)" for t, n in self.dropped.items()]
            parts += [f"{t} {n} (too large)" for t, n in self.oversize.items()]
            line += " (" + ", ".join(parts) + ")"
        return line


def codec_of(t: RecordedTopic) -> Codec:
    """How a recorded topic's values are encoded in the rings (and in the file)."""
    cls: type = {"float": float, "int": int, "bool": bool, "str": str}.get(t.kind, float)
    if t.kind == "float_array":
        import numpy as np

        cls = np.ndarray
    elif t.kind in ("ros2", "ros1"):
        cls = _message_class(t)
    codec = codec_for(cls)
    assert codec is not None
    return codec


def _message_class(t: RecordedTopic) -> type:
    try:
        return message_class(t.type_name)
    except LookupError as exc:
        raise ConfigurationError(f"--record: topic {t.topic}: {exc}") from None
