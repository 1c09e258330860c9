"""Reading a recording back: the MCAP files of ``rtcf launch --record`` and ``rtcf replay``.

One reader for every tool that looks at a recording (``rtcf diff``, ``rtcf plot``,
``rtcf replay``, ``rtcf evaluate``): per topic its schema and its messages in the
file's order, undecoded, with the sequence numbers unwrapped past 2^32 into the
iterations they were; the run's ``rtcf`` metadata and the attachments. It reads with
the ``mcap`` and ``mcap-ros2-support`` packages (``pip install 'rtcf[record]'``),
imported only when a file is read.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._core._errors import ConfigurationError, RtcfError
from ._mcap import RECORD_HINT

_WRAP = 1 << 32  # an MCAP sequence number is a uint32
_MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Message:
    iteration: int  # the sequence, unwrapped past 2^32
    log_time: int  # ns
    data: bytes  # the CDR bytes


@dataclass
class Recording:
    """One MCAP file: per topic its schema and its messages in the file's order."""

    path: str
    schemas: dict[str, Any] = field(default_factory=dict)  # topic -> mcap Schema
    encodings: dict[str, str] = field(default_factory=dict)  # topic -> message encoding
    messages: dict[str, list[Message]] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)  # the 'rtcf' record
    attachments: dict[str, bytes] = field(default_factory=dict)  # launch file, settings, ...
    start_ns: int = 0  # the log time of the file's first message
    end_ns: int = 0  # and of its last

    @property
    def name(self) -> str:
        return Path(self.path).name

    def type_name(self, topic: str) -> str:
        schema = self.schemas.get(topic)
        return schema.name if schema is not None else "?"

    def seconds(self, log_time: int) -> float:
        return (log_time - self.start_ns) / 1e9

    def decoder(self, topic: str) -> Callable[[bytes], Any]:
        from mcap_ros2.decoder import DecoderFactory

        decode = DecoderFactory().decoder_for(self.encodings[topic], self.schemas[topic])
        if decode is None:
            raise ConfigurationError(
                f"{self.path}: {topic} is encoded as {self.encodings[topic]!r} with a "
                f"{self.schemas[topic].encoding!r} schema, which rtcf cannot decode"
            )
        return decode


def read_recording(path: str, select: Callable[[str], bool] | None = None) -> Recording:
    """Every message of the topics ``select`` accepts (default: all), not decoded.

    Raises :class:`ConfigurationError` (one line naming the file) when the file is
    missing or not a readable MCAP file.
    """
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
                    rec.schemas[topic] = schema
                    rec.encodings[topic] = channel.message_encoding
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
