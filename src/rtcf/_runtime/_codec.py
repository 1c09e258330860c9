"""How a port value crosses the process boundary: as bytes, chosen by the port's type.

Values that go to or come from the middleware cross from the worker to the supervisor
(and back) through shared memory, so they must become bytes. float, int, bool and str
are packed as they are (no middleware is needed in the worker for them); a 1-D float
numpy array as its float64 bytes; a ROS 2 message class as the CDR bytes of
``rclpy.serialization`` (which loads rclpy's type support, not its client library:
no context, no node, no thread), or, for a :class:`rtcf.Serialized` of that class
written to the port, the bytes it holds already (no message is built in the loop); a
ROS 1 message class as the bytes of its own ``serialize`` (genpy: pure Python, imports
no rospy).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from io import BytesIO
from typing import Any

from .._core._cdr import Serialized, example_fields
from .._core._errors import ConfigurationError
from .._core._message_types import is_ros1_message, is_ros2_message, type_name

_F64 = struct.Struct("<d")
_I64 = struct.Struct("<q")


@dataclass(frozen=True)
class Codec:
    """Encoding of one port type: ``encode(value) -> bytes`` and back."""

    kind: str  # "float", "int", "bool", "str", "float_array", "ros2" or "ros1"
    encode: Callable[[Any], bytes]
    decode: Callable[[bytes], Any]
    max_size: int  # bytes a record of this type may take in a channel
    # decode the first n bytes of a buffer; fixed-size kinds read it in place, with
    # no copy (the worker's feeders, once per new message, in the loop)
    decode_from: Callable[[bytearray, int], Any] | None = None

    def decode_buffer(self) -> Callable[[bytearray, int], Any]:
        if self.decode_from is not None:
            return self.decode_from
        decode = self.decode

        def copy_and_decode(buf: bytearray, n: int) -> Any:
            return decode(bytes(buf[:n]))

        return copy_and_decode


def _encode_str(v: Any) -> bytes:
    return str(v).encode("utf-8")


def _decode_str(b: bytes) -> str:
    return b.decode("utf-8", "replace")


def _encode_array(v: Any) -> bytes:
    import numpy as np

    return np.ascontiguousarray(v, dtype=np.float64).tobytes()


def _decode_array(b: bytes) -> Any:
    import numpy as np

    return np.frombuffer(b, dtype=np.float64).copy()


def _encode_ros1(msg: Any) -> bytes:
    buf = BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def codec_for(cls: type, *, max_message_bytes: int = 64 * 1024) -> Codec | None:
    """The codec of a port type, or None if values of it cannot cross."""
    if cls is bool:
        return Codec(
            "bool", lambda v: b"\x01" if v else b"\x00", lambda b: b != b"\x00", 1,
            lambda buf, n: buf[0] != 0,
        )
    if cls is int:
        return Codec(
            "int", _I64.pack, lambda b: _I64.unpack(b)[0], 8,
            lambda buf, n: _I64.unpack_from(buf)[0],
        )
    if cls is float:
        return Codec(
            "float", lambda v: _F64.pack(float(v)), lambda b: _F64.unpack(b)[0], 8,
            lambda buf, n: _F64.unpack_from(buf)[0],
        )
    if cls is str:
        return Codec("str", _encode_str, _decode_str, max_message_bytes)
    if cls.__module__ == "numpy" and cls.__name__ == "ndarray":
        return Codec("float_array", _encode_array, _decode_array, max_message_bytes)
    if is_ros2_message(cls):
        from rclpy.serialization import deserialize_message, serialize_message

        def decode(b: bytes, _cls: type = cls) -> Any:
            return deserialize_message(b, _cls)

        _warm(lambda: decode(serialize_message(cls())))
        _check_serialized(cls)
        return Codec("ros2", _ros2_encoder(cls, serialize_message), decode, max_message_bytes)
    if is_ros1_message(cls):

        def decode1(b: bytes, _cls: type = cls) -> Any:
            return _cls().deserialize(b)

        _warm(lambda: decode1(_encode_ros1(cls())))
        return Codec("ros1", _encode_ros1, decode1, max_message_bytes)
    return None


def _ros2_encoder(cls: type, serialize: Callable[[Any], bytes]) -> Callable[[Any], bytes]:
    """A message's CDR bytes: a Serialized's own (the bytearray itself: every caller
    copies them into its channel at once), else rclpy's."""

    def encode(value: Any) -> Any:
        if type(value) is Serialized:
            if value.message_class is not cls:
                raise TypeError(
                    f"a Serialized({type_name(value.message_class)}) was written to a port "
                    f"of {type_name(cls)}"
                )
            return value._cdr
        return serialize(value)

    return encode


_checked: dict[type, bool] = {}


def _check_serialized(cls: type) -> None:
    """Once per message class, where its codec is made: a Serialized of it, with an
    element in every sequence and text in every string, gives bytes that rclpy reads
    back as the same message and that equal rclpy's own but for padding."""
    if cls in _checked:
        return
    from rclpy.serialization import deserialize_message, serialize_message

    try:
        ours = Serialized(cls, **example_fields(cls))
    except (TypeError, ValueError, LookupError):
        _checked[cls] = False  # a type Serialized cannot lay out: none can be written
        return
    message = ours.to_message()
    if not ours.same_but_padding(serialize_message(message)) or (
        deserialize_message(bytes(ours), cls) != message
    ):
        raise ConfigurationError(
            f"rtcf.Serialized lays {type_name(cls)} out otherwise than rclpy serializes it "
            "(a changed encoding?); write rosidl messages to its ports, and report it"
        )
    _checked[cls] = True


def _warm(round_trip: Callable[[], Any]) -> None:
    """One round trip of a default message, where the codec is made (before the loop):
    the first loads the type's support (imports, milliseconds), which would otherwise
    happen at the first write in the loop (19 ms measured for sensor_msgs/JointState)."""
    try:
        round_trip()
    except Exception:
        pass  # a type that cannot make a default message: its first use says why
