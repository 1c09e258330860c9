"""A ROS 2 message as its CDR bytes, laid out once and written in the loop as numbers.

Building a rosidl message and serializing it costs more than the numbers it carries
(issue 32: a 7-joint JointState, 4.5x the same 21 floats as one array). Where the
shape is known at configure time (the joint names, how many joints), the bytes can be
laid out then, and the loop only stores numbers into them. :class:`Serialized` does
that: it reads the message class's ``get_fields_and_field_types()`` (rosidl's
generated classes have it; nothing of rclpy is imported: the core knows no
middleware), writes XCDR1 little-endian bytes as Fast DDS does for Jazzy into one
bytearray, and hands out numpy views of its numeric fields. Strings and sequence
lengths are fixed at construction; numbers are written through the views.

The encoding: a 4-byte header ``00 01 00 00``; offsets count from the byte after it;
a primitive is aligned to its size (1, 2, 4 or 8); a string is a uint32 length
(with its NUL), its bytes and a NUL, aligned to 4; a sequence is a uint32 count,
aligned to 4, then its elements (the first aligned to its type, when there is one);
an array ``T[N]`` has no count; a nested message is inline. Padding bytes are zero
(rclpy leaves them uninitialised), so equal messages give equal bytes.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from ._message_types import message_class, type_name

__all__ = ["Serialized"]

_HEADER = b"\x00\x01\x00\x00"  # CDR, little-endian, no options
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")  # builtin_interfaces/Time: sec, nanosec

# rosidl's primitive type names -> numpy's little-endian dtype (its itemsize is the
# field's size and alignment)
_PRIMITIVES: dict[str, str] = {
    "boolean": "?", "byte": "u1", "octet": "u1", "char": "u1", "uint8": "u1", "int8": "i1",
    "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4", "int64": "<i8",
    "uint64": "<u8", "float": "<f4", "double": "<f8", "float32": "<f4", "float64": "<f8",
}
_AS_BYTES = ("byte", "octet")  # rosidl's Python type for these is bytes of length 1
_SEQUENCE = re.compile(r"^sequence<(.+?)(?:,\s*(\d+))?>$")
_ARRAY = re.compile(r"^(.+)\[(\d+)\]$")
_STRING = re.compile(r"^string(?:<=(\d+))?$")


class _Field:
    """One field of the layout: where it is and what it holds."""

    __slots__ = ("count", "dtype", "kind", "offset", "value", "view")

    def __init__(self, kind: str, offset: int = 0, dtype: str = "", count: int = -1,
                 value: Any = None) -> None:
        self.kind = kind  # "number", "numbers", "string", "strings", "struct", "structs"
        self.offset = offset  # in the bytes, header included
        self.dtype = dtype
        self.count = count  # -1: one number; else how many
        self.value = value  # a string's text, strings' tuple, a struct's _Struct, ...
        self.view: np.ndarray | None = None  # numbers: set when the bytes are final


class _Struct:
    """A nested message of a Serialized: its fields as attributes, read as a rosidl
    message's are (numbers, numpy views of sequences, strings), numbers also written.

    Every field but a single number is an entry of the instance's ``__dict__`` once the
    bytes are final (:meth:`_bind`), so ``js.position`` is one dictionary look-up (the
    loop's path); a single number is read through ``__getattr__``."""

    def __init__(self, cls: type, fields: dict[str, _Field]) -> None:
        self.__dict__["_cls"] = cls
        self.__dict__["_fields"] = fields

    def _bind(self, into: dict[str, Any], skip: Any = ()) -> None:
        for name, field in self._fields.items():
            if field.kind == "struct":
                field.value._bind(field.value.__dict__)
            elif field.kind == "structs":
                for s in field.value:
                    s._bind(s.__dict__)
            if field.kind != "number" and name not in skip:
                into.setdefault(name, field.view if field.kind == "numbers" else field.value)

    def __getattr__(self, name: str) -> Any:
        field = self.__dict__["_fields"].get(name)
        if field is None:
            raise AttributeError(f"{type_name(self._cls)} has no field {name!r}")
        assert field.kind == "number" and field.view is not None
        return field.view[0].item()

    def __setattr__(self, name: str, value: Any) -> None:
        field = self._fields.get(name)
        if field is None or field.kind not in ("number", "numbers"):
            raise AttributeError(
                f"{type_name(self._cls)}.{name}: only numbers can be written into a "
                "Serialized (its strings and sequence lengths are fixed when it is made)"
            )
        assert field.view is not None
        field.view[:] = value

    def _message(self) -> Any:
        msg = self._cls()
        for name, field in self._fields.items():
            setattr(msg, name, _message_value(field))
        return msg


def _message_value(field: _Field) -> Any:
    kind, view = field.kind, field.view
    if kind == "number":
        assert view is not None
        value = view[0].item()
        if field.value in _AS_BYTES:
            return bytes([value])
        return chr(value) if field.value == "char" else value
    if kind == "numbers":
        assert view is not None
        if field.value in _AS_BYTES:
            return [bytes([v]) for v in view.tolist()]
        if field.value == "char":
            return [chr(v) for v in view.tolist()]
        return view.tolist()  # rosidl takes lists for sequences and arrays alike
    if kind == "strings":
        return list(field.value)
    if kind == "struct":
        return field.value._message()
    if kind == "structs":
        return [s._message() for s in field.value]
    return field.value  # a string


class Serialized:
    """A ROS 2 message laid out as its CDR bytes at configure time, for a loop that
    writes only numbers into it.

    ``Serialized(JointState, name=["j1", "j2"], position=2, velocity=2, effort=2)``:
    keyword arguments give the fields (nested ones as dicts, or dotted:
    ``**{"header.frame_id": "base_link"}``). Strings are fixed; a sequence of numbers
    is given its length (an int) or its values; a sequence of messages its elements
    (dicts, messages, or how many); numbers their initial values. Fields not given are
    zero, empty strings and empty sequences. ``Serialized.of(msg)`` takes all of them
    from a message.

    In the loop, write numbers through the views (no message object is built, nothing
    allocated): ``js.position[:] = q`` (a float64 view of the sequence),
    ``js.stamp_ns = self.stamp_ns`` (``header.stamp``),
    ``odom.view("pose.pose.position")[:] = (x, y, 0.0)`` (a view of any numeric field,
    or of a message whose fields are numbers of one type, in order: a Point, a
    Quaternion), ``odom.view("pose.covariance")``. Then ``port.write(js)``: an output
    port of the message's class takes it, and a mapped one publishes its bytes as they
    are. Attributes read as the message's fields (``js.name``, ``js.header.frame_id``,
    ``js.header.stamp.sec``). ``to_message()`` makes the rosidl message (allocates).
    """

    def __init__(self, message_class: type, /, **fields: Any) -> None:
        if not hasattr(message_class, "get_fields_and_field_types"):
            raise TypeError(
                f"Serialized: {message_class!r} is not a ROS 2 message class (it has no "
                "get_fields_and_field_types(); pass e.g. sensor_msgs.msg.JointState)"
            )
        self.message_class = message_class
        layout = _Layout()
        self._root = layout.struct(message_class, _nest(fields), type_name(message_class))
        #: the message's bytes: the header and the fields (rtcf publishes them as they are)
        self._cdr = layout.finish()
        for field in layout.numbers:
            field.view = np.frombuffer(
                self._cdr, dtype=field.dtype, count=max(field.count, 1), offset=field.offset
            )
        self._stamp_at = _stamp_offset(self._root)
        self._data = tuple(layout.used)  # (start, end) of the bytes that are not padding
        # the fields as attributes (one look-up each), but where a name is rtcf's
        self._root._bind(self.__dict__, skip=_OWN)

    @classmethod
    def of(cls, message: Any) -> Serialized:
        """A Serialized with the fields, strings and sequence lengths of ``message``."""
        names = type(message).get_fields_and_field_types()
        return cls(type(message), **{name: getattr(message, name) for name in names})

    @property
    def stamp_ns(self) -> int:
        """``header.stamp`` in nanoseconds; set it to stamp the message (one store)."""
        at = self._stamp_at
        if at < 0:
            raise AttributeError(f"{type_name(self.message_class)} has no header.stamp")
        sec, nanosec = _TIME.unpack_from(self._cdr, at)
        return int(sec) * 1_000_000_000 + int(nanosec)

    @stamp_ns.setter
    def stamp_ns(self, t: int) -> None:
        at = self._stamp_at
        if at < 0:
            raise AttributeError(f"{type_name(self.message_class)} has no header.stamp")
        _TIME.pack_into(self._cdr, at, t // 1_000_000_000, t % 1_000_000_000)

    def stamp_setter(self, path: str) -> Callable[[int], None]:
        """A function that stores a time in nanoseconds into the ``builtin_interfaces/Time``
        at ``path`` (``"transforms[0].header.stamp"``): for the loop, as ``stamp_ns``
        is for ``header.stamp``."""
        field = self._find(path)
        at = _time_offset(field.value) if field.kind == "struct" else -1
        if at < 0:
            raise ValueError(
                f"Serialized({type_name(self.message_class)}): {path!r} is not a "
                "builtin_interfaces/Time"
            )
        cdr, pack = self._cdr, _TIME.pack_into

        def set_stamp(t: int) -> None:
            pack(cdr, at, t // 1_000_000_000, t % 1_000_000_000)

        return set_stamp

    def view(self, path: str) -> np.ndarray:
        """The numpy view of a numeric field, by its dotted path: a number's is of
        length 1 (``view("twist.twist.angular.z")[0] = w``); a sequence's or an
        array's holds its elements; a message's whose fields are all numbers of one
        type, back to back (Point, Quaternion, Vector3), holds them in order.
        Elements of a sequence of messages are indexed: ``"transforms[0].transform"``.
        """
        field = self._find(path)
        if field.view is not None:
            return field.view
        if field.kind == "struct":
            view = _packed_view(self._cdr, field.value)
            if view is not None:
                return view
        raise ValueError(
            f"Serialized({type_name(self.message_class)}).view({path!r}): not a number, "
            "a sequence of numbers, or a message of numbers of one type"
        )

    def to_message(self) -> Any:
        """The rosidl message with these values (allocates: not for the loop)."""
        return self._root._message()

    def __bytes__(self) -> bytes:
        return bytes(self._cdr)

    def __len__(self) -> int:
        return len(self._cdr)

    def __getattr__(self, name: str) -> Any:  # a single number (or no such field)
        root = self.__dict__.get("_root")
        if root is None or name.startswith("__"):
            raise AttributeError(name)
        return getattr(root, name)

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "stamp_ns":  # the loop's: no property call on top of this one
            at = self._stamp_at
            if at >= 0:
                _TIME.pack_into(self._cdr, at, value // 1_000_000_000, value % 1_000_000_000)
                return
        root = self.__dict__.get("_root")
        if root is not None and name in root._fields:
            setattr(root, name, value)  # numbers into their bytes; the rest refused
        else:
            object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        return f"<Serialized {type_name(self.message_class)}: {len(self._cdr)} bytes>"

    def _find(self, path: str) -> _Field:
        node = _Field("struct", value=self._root)
        where = type_name(self.message_class)
        for part in re.split(r"\.(?![^\[]*\])", path):
            m = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part)
            fields = node.value._fields if node.kind == "struct" else None
            if m is None or fields is None or m.group(1) not in fields:
                raise KeyError(f"Serialized({where}): no field {path!r}")
            node = fields[m.group(1)]
            if m.group(2) is not None:
                if node.kind != "structs" or int(m.group(2)) >= len(node.value):
                    raise KeyError(f"Serialized({where}): {path!r}: index out of range")
                node = _Field("struct", value=node.value[int(m.group(2))])
        return node

    def same_but_padding(self, other: bytes) -> bool:
        """True if ``other`` (rclpy's bytes of the same message) holds these bytes but
        for padding, which rclpy leaves uninitialised (and may add at the end)."""
        if len(other) < len(self._cdr) or other[:4] != self._cdr[:4]:
            return False
        return all(other[a:b] == self._cdr[a:b] for a, b in self._data)


_OWN = frozenset(dir(Serialized))


class _Layout:
    """Lays a message's fields out into bytes, in order, aligned."""

    def __init__(self) -> None:
        self.buf = bytearray(_HEADER)
        self.numbers: list[_Field] = []
        self.used: list[tuple[int, int]] = []  # (start, end) of every byte that is data

    def align(self, size: int) -> None:
        self.buf += b"\x00" * (-(len(self.buf) - 4) % size)

    def put(self, data: bytes) -> int:
        at = len(self.buf)
        self.buf += data
        self.used.append((at, len(self.buf)))
        return at

    def finish(self) -> bytearray:
        return self.buf

    def struct(self, cls: type, values: Mapping[str, Any], where: str) -> _Struct:
        types = cls.get_fields_and_field_types()  # type: ignore[attr-defined]
        unknown = set(values) - set(types)
        if unknown:
            raise TypeError(
                f"Serialized({where}): no field {sorted(unknown)[0]!r} "
                f"(its fields: {', '.join(types)})"
            )
        fields = {
            name: self.field(ftype, values.get(name), f"{where}.{name}")
            for name, ftype in types.items()
        }
        return _Struct(cls, fields)

    def field(self, ftype: str, value: Any, where: str) -> _Field:
        m = _SEQUENCE.match(ftype)
        if m:
            bound = int(m.group(2)) if m.group(2) else None
            return self.sequence(m.group(1), value, bound, where)
        m = _ARRAY.match(ftype)
        if m:
            return self.array(m.group(1), int(m.group(2)), value, where)
        if ftype in _PRIMITIVES:
            field = self.number(ftype, -1, where)
            if value is not None:
                _initial(field, self.buf, [value], where)
            return field
        m = _STRING.match(ftype)
        if m:
            text = "" if value is None else value
            if not isinstance(text, str):
                raise TypeError(f"Serialized({where}): a string, not {text!r}")
            self.string(text, int(m.group(1)) if m.group(1) else None, where)
            return _Field("string", value=text)
        if "/" in ftype:
            return _Field("struct", value=self.nested(ftype, value, where))
        raise TypeError(f"Serialized({where}): fields of type {ftype!r} are not supported")

    def number(self, ftype: str, count: int, where: str) -> _Field:
        dtype = _PRIMITIVES[ftype]
        size = np.dtype(dtype).itemsize
        if count:
            self.align(size)
        field = _Field("number" if count < 0 else "numbers", len(self.buf), dtype, count, ftype)
        if count:
            self.put(b"\x00" * size * max(count, 1))
            self.numbers.append(field)
        else:
            field.view = np.zeros(0, dtype=dtype)
        return field

    def string(self, text: str, bound: int | None, where: str) -> None:
        data = text.encode("utf-8")
        if b"\x00" in data or (bound is not None and len(text) > bound):
            raise ValueError(f"Serialized({where}): {text!r} is not a string of this field")
        self.align(4)
        self.put(_U32.pack(len(data) + 1) + data + b"\x00")

    def nested(self, ftype: str, value: Any, where: str) -> _Struct:
        cls = message_class(ftype)
        if value is None:
            value = {}
        elif isinstance(value, cls):
            value = {n: getattr(value, n) for n in cls.get_fields_and_field_types()}  # type: ignore[attr-defined]
        if not isinstance(value, Mapping):
            raise TypeError(f"Serialized({where}): a dict of {ftype}'s fields, not {value!r}")
        return self.struct(cls, value, where)

    def sequence(self, elem: str, value: Any, bound: int | None, where: str) -> _Field:
        items = _items(value, where)
        if bound is not None and len(items) > bound:
            raise ValueError(f"Serialized({where}): {len(items)} elements, at most {bound}")
        self.align(4)
        self.put(_U32.pack(len(items)))
        return self.elements(elem, items, where)

    def array(self, elem: str, n: int, value: Any, where: str) -> _Field:
        items = _items(n if value is None else value, where)
        if len(items) != n:
            raise ValueError(f"Serialized({where}): {len(items)} elements, the array has {n}")
        return self.elements(elem, items, where)

    def elements(self, elem: str, items: list[Any], where: str) -> _Field:
        if elem in _PRIMITIVES:
            field = self.number(elem, len(items), where)
            if any(v is not None for v in items):
                _initial(field, self.buf, items, where)
            return field
        m = _STRING.match(elem)
        if m:
            bound = int(m.group(1)) if m.group(1) else None
            texts = tuple("" if v is None else v for v in items)
            for k, text in enumerate(texts):
                if not isinstance(text, str):
                    raise TypeError(f"Serialized({where}[{k}]): a string, not {text!r}")
                self.string(text, bound, f"{where}[{k}]")
            return _Field("strings", value=texts)
        if "/" in elem:
            structs = tuple(self.nested(elem, v, f"{where}[{k}]") for k, v in enumerate(items))
            return _Field("structs", value=structs)
        raise TypeError(f"Serialized({where}): elements of type {elem!r} are not supported")


def _items(value: Any, where: str) -> list[Any]:
    """A sequence's elements as given: how many (an int: defaults), or the values."""
    if value is None:
        return []
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return [None] * int(value)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"Serialized({where}): a length or the elements, not {value!r}")
    return list(value)


def _initial(field: _Field, buf: bytearray, values: list[Any], where: str) -> None:
    """Write the initial values of a numeric field (before the views exist)."""
    if field.dtype == "u1":
        values = [v[0] if isinstance(v, bytes) else ord(v) if isinstance(v, str) else v
                  for v in values]
    try:
        data = np.asarray(values, dtype=field.dtype).tobytes()
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"Serialized({where}): numbers, not {values!r}") from None
    buf[field.offset : field.offset + len(data)] = data


def _nest(fields: Mapping[str, Any]) -> dict[str, Any]:
    """``{"header.frame_id": x}`` -> ``{"header": {"frame_id": x}}``."""
    out: dict[str, Any] = {}
    for key, value in fields.items():
        head, _, rest = key.partition(".")
        if rest:
            inner = out.setdefault(head, {})
            if not isinstance(inner, dict):
                raise TypeError(f"Serialized: both {head!r} and {key!r} given")
            inner.update(_nest({rest: value}))
        else:
            out[key] = value
    return out


def _stamp_offset(root: _Struct) -> int:
    """Where ``header.stamp`` starts in the bytes, or -1."""
    header = root._fields.get("header")
    if header is None or header.kind != "struct":
        return -1
    stamp = header.value._fields.get("stamp")
    return -1 if stamp is None or stamp.kind != "struct" else _time_offset(stamp.value)


def _time_offset(time: _Struct) -> int:
    """Where a Time's ``sec`` starts (its ``nanosec`` follows), or -1 if it is none."""
    sec, nanosec = time._fields.get("sec"), time._fields.get("nanosec")
    if sec is None or nanosec is None or (sec.dtype, nanosec.dtype) != ("<i4", "<u4"):
        return -1
    return sec.offset if nanosec.offset == sec.offset + 4 and len(time._fields) == 2 else -1


def _packed_view(cdr: bytearray, struct_: _Struct) -> np.ndarray | None:
    """A view of a message whose fields are numbers of one type, back to back."""
    fields = list(struct_._fields.values())
    if not fields or any(f.kind != "number" for f in fields):
        return None
    dtype = fields[0].dtype
    size = np.dtype(dtype).itemsize
    start = fields[0].offset
    if any(f.dtype != dtype or f.offset != start + k * size for k, f in enumerate(fields)):
        return None
    return np.frombuffer(cdr, dtype=dtype, count=len(fields), offset=start)



def example_fields(cls: type) -> dict[str, Any]:
    """Fields for a Serialized of ``cls`` that use every part of its layout: text in
    every string, elements in every sequence, a number other than 0 in every number
    (checks of the layout against rclpy's, where a codec is made, and the tests)."""
    counter = iter(range(1, 1 << 30))
    return _examples(cls, counter)


def _examples(cls: type, counter: Iterator[int]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, ftype in cls.get_fields_and_field_types().items():  # type: ignore[attr-defined]
        m = _SEQUENCE.match(ftype)
        a = _ARRAY.match(ftype)
        if m:
            elem, n = m.group(1), min(2, int(m.group(2) or 2))
        elif a:
            elem, n = a.group(1), int(a.group(2))
        else:
            out[name] = _example(ftype, counter)
            continue
        out[name] = [_example(elem, counter) for _ in range(n)]
    return out


def _example(ftype: str, counter: Iterator[int]) -> Any:
    if ftype in _PRIMITIVES:
        return True if ftype == "boolean" else next(counter) % 100 + 1
    m = _STRING.match(ftype)
    if m:
        return "abc"[: int(m.group(1) or 3)]
    return _examples(message_class(ftype), counter)
