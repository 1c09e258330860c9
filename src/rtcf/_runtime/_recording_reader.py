"""Reading a recording back: the MCAP files of ``rtcf launch --record`` and ``rtcf replay``.

One reader for everything that looks at a recording (``rtcf diff``, ``rtcf plot``,
``rtcf replay``, ``rtcf evaluate``, and users through :mod:`rtcf.recording`): per
topic its type and its messages in the file's order, undecoded, with the sequence
numbers unwrapped past 2^32 into the iterations they were; the run's ``rtcf``
metadata and the attachments; and a topic's numbers over time as numpy arrays
(:class:`Series`). Messages are decoded as ``mcap-ros2-support`` decodes CDR (the
``ros2msg`` schemas rtcf writes for every port but a ROS 1 message's). It reads with
the ``mcap`` and ``mcap-ros2-support`` packages (``pip install 'rtcf[record]'``),
imported only when a file is read.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .._core._errors import ConfigurationError, RtcfError
from ._mcap import RECORD_HINT

_WRAP = 1 << 32  # an MCAP sequence number is a uint32
_MAGIC = b"\x89MCAP0\r\n"
_NUMBER = (bool, int, float, np.bool_, np.integer, np.floating)


@dataclass
class Message:
    """One recorded message, undecoded."""

    iteration: int  # the loop iteration it was written in (the sequence, unwrapped)
    log_time: int  # ns: the iteration's stamp (ROS time of its scheduled start)
    data: bytes  # the serialized message (CDR; ROS 1's own for a ROS 1 message)


@dataclass(frozen=True, eq=False)  # arrays: no element-wise == of two series
class Series:
    """One topic's numbers over time: one row per message, in the file's order.

    ``values`` is ``(n,)`` where every message holds one number (a ``float``, ``int``
    or ``bool`` port: float64, int64 or bool, exactly as written), else ``(n, k)``
    with a column per number: per element of an array (NaN where a message has
    fewer), per numeric field of a message (its ``header`` left out). ``labels``
    names the columns (``data``, ``data[0]``, ``point.x``).
    """

    topic: str
    type_name: str  # the message type, e.g. std_msgs/msg/Float64
    field: str  # the field the numbers come from (dotted; "": the whole message)
    labels: list[str]
    iterations: npt.NDArray[np.int64]  # the loop iteration of each message
    t_ns: npt.NDArray[np.int64]  # its stamp (ROS time, ns)
    t_s: npt.NDArray[np.float64]  # seconds from the file's first message
    values: npt.NDArray[Any]

    def __len__(self) -> int:
        return len(self.t_ns)


class SeriesError(ConfigurationError):
    """A topic's messages have no field ``field`` (``fields``: those they have), or
    it holds no numbers (``fields`` is None)."""

    def __init__(
        self, message: str, topic: str, field: str, fields: list[str] | None = None
    ) -> None:
        super().__init__(message)
        self.topic = topic
        self.field = field
        self.fields = fields


class Recording:
    """One recording: per topic its type and its messages in the file's order.

    ``messages`` maps each topic to its :class:`Message` list (undecoded); ``metadata``
    is the run's ``rtcf`` record as the file holds it (strings; JSON text for numbers,
    lists and maps), ``attachments`` the files it carries (``launch/<file>``,
    ``settings.json``, ``timing.json``). ``start_ns`` and ``end_ns`` are the log
    times of the file's first and last message.
    """

    def __init__(self, path: str) -> None:
        self.path = path
        self.messages: dict[str, list[Message]] = {}
        self.metadata: dict[str, str] = {}
        self.attachments: dict[str, bytes] = {}
        self.start_ns = 0
        self.end_ns = 0
        self._schemas: dict[str, Any] = {}  # topic -> mcap Schema
        self._encodings: dict[str, str] = {}  # topic -> message encoding
        self._decoders: Any = None  # mcap-ros2-support's, which caches per schema

    def __repr__(self) -> str:
        return f"<Recording {self.path}: {len(self.messages)} topics>"

    @property
    def name(self) -> str:
        """The file's name."""
        return Path(self.path).name

    @property
    def topics(self) -> list[str]:
        """The topics that have messages, by name."""
        return sorted(self.messages)

    @property
    def types(self) -> dict[str, str]:
        """Each topic's message type (``std_msgs/msg/Float64``, ...), by topic."""
        return {t: self.type_name(t) for t in self.topics}

    def type_name(self, topic: str) -> str:
        """The message type of ``topic`` (``?`` for a channel without a schema)."""
        schema = self._schemas.get(topic)
        return schema.name if schema is not None else "?"

    def definition(self, topic: str) -> str:
        """The message definition the file carries for ``topic`` (its schema's text)."""
        schema = self._schemas.get(topic)
        return schema.data.decode(errors="surrogateescape") if schema is not None else ""

    def seconds(self, log_time: int) -> float:
        """A log time (ns) as seconds from the file's first message."""
        return (log_time - self.start_ns) / 1e9

    def decoder(self, topic: str) -> Callable[[bytes], Any]:
        """A function from a message's ``data`` to the message (CDR, ``ros2msg``)."""
        if self._decoders is None:
            from mcap_ros2.decoder import DecoderFactory

            self._decoders = DecoderFactory()
        decode = self._decoders.decoder_for(self._encodings[topic], self._schemas[topic])
        if decode is None:
            raise ConfigurationError(
                f"{self.path}: {topic} is encoded as {self._encodings[topic]!r} with a "
                f"{self._schemas[topic].encoding!r} schema, which rtcf cannot decode"
            )
        return decode

    def series(self, topic: str, field: str | None = None) -> Series:
        """``topic``'s numbers over time: those of ``field`` (dotted, ``point.x``;
        default ``data`` where the message has it, else every number in it but its
        header). Raises :class:`~rtcf.ConfigurationError` when the topic is not in the
        file, or its messages have no such field or no numbers there."""
        if topic not in self.messages:
            listing = ", ".join(self.topics) or "none"
            raise ConfigurationError(f"{self.path} has no topic {topic!r}; its topics: {listing}")
        decode = self.decoder(topic)
        msgs = self.messages[topic]
        rows: list[list[Any]] = []
        labels: list[str] = []
        chosen = field
        scalar = True
        for m in msgs:
            decoded = decode(m.data)
            if chosen is None:
                chosen = "data" if "data" in (getattr(decoded, "__slots__", None) or ()) else ""
            try:
                value = _field(decoded, chosen) if chosen else decoded
            except KeyError:
                fields = list(getattr(decoded, "__slots__", None) or ())
                raise SeriesError(
                    f"{topic} ({self.type_name(topic)}) has no field {chosen!r}; its fields: "
                    + ", ".join(fields), topic, chosen, fields,
                ) from None
            numbers = _numeric(value, chosen)
            if numbers is None:
                raise SeriesError(
                    f"{topic} ({self.type_name(topic)}): {chosen or 'the message'} holds no "
                    "numbers", topic, chosen,
                )
            scalar = scalar and isinstance(value, _NUMBER)
            if len(numbers) > len(labels):
                labels = [label for label, _ in numbers]
            rows.append([v for _, v in numbers])
        t_ns = np.array([m.log_time for m in msgs], dtype=np.int64)
        return Series(
            topic,
            self.type_name(topic),
            chosen or "",
            labels,
            np.array([m.iteration for m in msgs], dtype=np.int64),
            t_ns,
            np.array([self.seconds(m.log_time) for m in msgs], dtype=np.float64),
            _table(rows, len(labels), scalar),
        )


def _field(message: Any, path: str) -> Any:
    value = message
    for part in path.split("."):
        if part not in (getattr(value, "__slots__", None) or ()):
            raise KeyError(part)
        value = getattr(value, part)
    return value


def _numeric(value: Any, path: str) -> list[tuple[str, Any]] | None:
    """The numbers a field holds, with their labels; None if it holds none."""
    if isinstance(value, _NUMBER):
        return [(path, value)]
    if isinstance(value, (list, tuple, np.ndarray)):
        if all(isinstance(v, _NUMBER) for v in value):
            return [(f"{path}[{k}]", v) for k, v in enumerate(value)]
        return None
    if getattr(value, "__slots__", None) is not None and not isinstance(value, str):
        out: list[tuple[str, Any]] = []
        for name in value.__slots__:
            if name == "header":  # stamps and frame ids are not signals
                continue
            sub = _numeric(getattr(value, name), f"{path}.{name}" if path else name)
            if sub is not None:
                out.extend(sub)
        return out or None
    return None


def _table(rows: list[list[Any]], width: int, scalar: bool) -> npt.NDArray[Any]:
    """The rows as one array: their own dtype where they are all as wide and numpy
    holds them exactly (bool, int64, uint64, float64), else float64 with NaN padding."""
    values: npt.NDArray[Any] | None = None
    if all(len(r) == width for r in rows):
        try:
            values = np.array(rows).reshape(len(rows), width)
        except OverflowError:
            values = None
        if values is not None and values.dtype.kind not in "biuf":
            values = None
    if values is None:
        values = np.full((len(rows), width), np.nan)
        for k, r in enumerate(rows):
            values[k, : len(r)] = [float(v) for v in r]
    return values[:, 0] if scalar and width == 1 else values


def read(
    path: str | os.PathLike[str],
    topics: Iterable[str] | Callable[[str], bool] | None = None,
) -> Recording:
    """Read a recording: every message of ``topics`` (a name, several, or a function
    that says yes to a topic's name; default: all), undecoded, and the run's metadata.

    Raises :class:`~rtcf.ConfigurationError` (one line naming the file) when the file
    is missing or not a readable MCAP file, or the ``mcap`` packages are not installed.
    """
    path = os.fspath(path)
    if topics is None or callable(topics):
        select = topics
    else:
        names = {topics} if isinstance(topics, str) else set(topics)
        select = names.__contains__
    try:
        from mcap.reader import make_reader
    except ImportError:
        raise ConfigurationError(
            f"{path}: the mcap packages are not installed; {RECORD_HINT}"
        ) from None
    rec = Recording(path)
    last: dict[str, int] = {}
    start, end = None, None
    try:
        with open(path, "rb") as f:
            if f.read(len(_MAGIC)) != _MAGIC:
                raise ConfigurationError(f"{path}: not an MCAP file (no MCAP magic at its start)")
            f.seek(0)
            reader = make_reader(f)
            summary = reader.get_summary()
            if summary is not None:
                for m in reader.iter_metadata():
                    if m.name == "rtcf":
                        rec.metadata = dict(m.metadata)
                rec.attachments = {a.name: bytes(a.data) for a in reader.iter_attachments()}
                if summary.statistics is not None and summary.statistics.message_count:
                    start = summary.statistics.message_start_time
                    end = summary.statistics.message_end_time
            wanted = None
            if select is not None and summary is not None:
                wanted = [c.topic for c in summary.channels.values() if select(c.topic)]
            for schema, channel, message in reader.iter_messages(
                topics=wanted, log_time_order=False
            ):
                topic = channel.topic
                if select is not None and not select(topic):
                    continue
                if topic not in rec.messages:
                    rec.messages[topic] = []
                    rec._schemas[topic] = schema
                    rec._encodings[topic] = channel.message_encoding
                seq = message.sequence
                previous = last.get(topic)
                if previous is not None and seq < previous % _WRAP:
                    seq += (previous // _WRAP + 1) * _WRAP  # the uint32 wrapped
                elif previous is not None:
                    seq += previous // _WRAP * _WRAP
                last[topic] = seq
                rec.messages[topic].append(Message(seq, message.log_time, bytes(message.data)))
                if summary is None or summary.statistics is None:
                    start = message.log_time if start is None else min(start, message.log_time)
                    end = message.log_time if end is None else max(end, message.log_time)
    except OSError as exc:
        raise ConfigurationError(f"{path}: cannot read it: {exc.strerror}") from None
    except RtcfError:
        raise
    except Exception as exc:  # the mcap library's errors: truncated, corrupt
        raise ConfigurationError(f"{path}: not a readable MCAP file ({exc})") from None
    rec.start_ns = start or 0
    rec.end_ns = end or 0
    return rec
