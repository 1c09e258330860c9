"""A live view of the recorded channels on Foxglove's WebSocket protocol.

With ``rtcf launch --foxglove`` the supervisor serves what the recording rings carry
through the maintained ``foxglove-sdk`` package (``pip install 'rtcf[live]'``), on
loopback unless ``--foxglove-host`` says otherwise, decimated per topic to
``--foxglove-rate`` messages per second of loop time so that a viewer keeps up. Floats,
ints, bools, strings and float arrays go out as JSON (``{"data": ...}`` with a JSON
schema); ROS 2 messages as their CDR bytes with their ``ros2msg`` definition. Open
Foxglove, "Open connection", ``ws://127.0.0.1:8765``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from .._core._errors import ConfigurationError
from ._codec import Codec
from ._mcap import codec_of
from ._recording import Record, RecordedTopic

LIVE_HINT = "install the live-view extra: pip install 'rtcf[live]'"

_JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "float": {"type": "object", "properties": {"data": {"type": "number"}}},
    "int": {"type": "object", "properties": {"data": {"type": "integer"}}},
    "bool": {"type": "object", "properties": {"data": {"type": "boolean"}}},
    "str": {"type": "object", "properties": {"data": {"type": "string"}}},
    "float_array": {
        "type": "object",
        "properties": {"data": {"type": "array", "items": {"type": "number"}}},
    },
}


class FoxgloveLive:
    """Serves the recorded topics live (a record sink, like :class:`McapRecording`)."""

    def __init__(
        self,
        host: str,
        port: int,
        rate_hz: float,
        pattern: str = ".*",
        *,
        message_definition: Callable[[str], str] | None = None,
        name: str = "rtcf",
    ) -> None:
        try:
            import foxglove
        except ImportError:
            raise ConfigurationError(
                f"--foxglove: foxglove-sdk is not installed; {LIVE_HINT}"
            ) from None
        self._foxglove = foxglove
        self.host = host
        self.pattern = pattern
        self._definition = message_definition
        self._every_ns = int(1e9 / rate_hz) if rate_hz > 0 else 0
        self._channels: dict[str, tuple[Any, Codec, str]] = {}
        self._last: dict[str, int] = {}
        self.sent = 0
        try:
            self.server = foxglove.start_server(name=name, host=host, port=port)
        except Exception as exc:  # the SDK's own error types: address in use, bad host
            raise ConfigurationError(
                f"--foxglove: cannot serve on {host}:{port}: {exc}"
            ) from None

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.server.port}"

    def begin(self, topics: list[RecordedTopic]) -> None:
        fg = self._foxglove
        for t in topics:
            if t.topic in self._channels:
                continue
            if t.kind in _JSON_SCHEMAS:
                channel = fg.Channel(t.topic, schema=_JSON_SCHEMAS[t.kind],
                                     message_encoding="json")
            elif t.kind == "ros2" and self._definition is not None:
                schema = fg.Schema(name=t.type_name, encoding="ros2msg",
                                   data=self._definition(t.type_name).encode())
                channel = fg.Channel(t.topic, schema=schema, message_encoding="cdr")
            else:
                continue  # ROS 1 messages: not served (the recording says why)
            self._channels[t.topic] = (channel, codec_of(t), t.kind)

    def write(self, record: Record) -> None:
        entry = self._channels.get(record.topic)
        if entry is None:
            return
        last = self._last.get(record.topic)
        if last is not None and record.stamp_ns - last < self._every_ns:
            return  # decimated: a viewer cannot take every value at loop rate
        self._last[record.topic] = record.stamp_ns
        channel, codec, kind = entry
        stamp = max(0, record.stamp_ns)
        if kind == "ros2":
            channel.log(record.payload, log_time=stamp)
        else:
            value = codec.decode(record.payload)
            data = [float(x) for x in value] if kind == "float_array" else value
            channel.log(json.dumps({"data": data}).encode(), log_time=stamp)
        self.sent += 1

    def end_run(self, dropped: dict[str, int], counts: dict[str, dict[str, int]]) -> None:
        pass

    def close(self) -> None:
        for channel, _, _ in self._channels.values():
            channel.close()
        self.server.stop()


class RecordSinks:
    """Several record sinks fed from one recording (a file and a live view)."""

    def __init__(self, *sinks: Any) -> None:
        self.sinks = [s for s in sinks if s is not None]
        self.pattern = self.sinks[0].pattern

    def begin(self, topics: list[RecordedTopic]) -> None:
        for s in self.sinks:
            s.begin(topics)

    def write(self, record: Record) -> None:
        for s in self.sinks:
            s.write(record)

    def end_run(self, dropped: dict[str, int], counts: dict[str, dict[str, int]]) -> None:
        for s in self.sinks:
            s.end_run(dropped, counts)

    def timing_rows(self, rows: Any, offset_ns: int) -> None:
        for s in self.sinks:
            if hasattr(s, "timing_rows"):
                s.timing_rows(rows, offset_ns)
