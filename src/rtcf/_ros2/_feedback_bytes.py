"""An action's feedback published as CDR bytes, through rclpy's action server's own publisher.

The loop sends feedback as the Feedback message's CDR bytes. rclpy publishes feedback
only as a message object (``ServerGoalHandle.publish_feedback``: a ``FeedbackMessage``
built in Python, converted to C and serialized again by rcl), so publishing through it
means deserializing each feedback in the supervisor first: about as much work as
building the message was in the loop. A second publisher of raw bytes on
``<action>/_action/feedback`` would be a second writer in the graph (``ros2 topic
info`` counts two; a client matches each on its own), so this one does not add one.

rcl does publish serialized bytes (``rcl_publish_serialized_message``), and the action
server's feedback publisher is an ``rcl_publisher_t`` inside ``rcl_action_server_t``:
rclpy hands out the server's address (``ActionServer._handle.pointer``), and its
implementation holds the goal, cancel and result services (one pointer each) then the
feedback publisher (rcl_action's ``action_server_impl.h``, unchanged from Humble to
Rolling). :class:`FeedbackBytes` finds that publisher, checks it is one (valid, on a
topic ending in ``/_action/feedback``), and publishes ``FeedbackMessage`` bytes: the
goal's 16-byte UUID, then the Feedback's CDR. A UUID is 16 bytes at offset 0, so the
Feedback that follows starts 8-aligned, as in its own CDR: its bytes go on unchanged.
Where any of that does not hold (another rcl, another rclpy), :func:`feedback_bytes`
returns None and the bridge decodes feedback and publishes it through rclpy as before.

One writer, so feedback keeps its order, and is published where rclpy's would be: in
the drain, before the goal's result is handed to rclpy.
"""

from __future__ import annotations

import ctypes
from typing import Any

FEEDBACK_SUFFIX = "/_action/feedback"
_HEADER = 4  # the CDR encapsulation: 00 01 00 00 (little-endian)
_UUID = 16


class _Allocator(ctypes.Structure):  # rcutils_allocator_t: unused by a publish
    _fields_ = [("allocate", ctypes.c_void_p), ("deallocate", ctypes.c_void_p),
                ("reallocate", ctypes.c_void_p), ("zero_allocate", ctypes.c_void_p),
                ("state", ctypes.c_void_p)]


class _Bytes(ctypes.Structure):  # rcl_serialized_message_t (rcutils_uint8_array_t)
    _fields_ = [("buffer", ctypes.c_void_p), ("buffer_length", ctypes.c_size_t),
                ("buffer_capacity", ctypes.c_size_t), ("allocator", _Allocator)]


_rcl: Any = None


def _library() -> Any:
    """librcl, as rclpy loaded it (by its soname), with the functions used here typed."""
    global _rcl
    if _rcl is None:
        rcl: Any = ctypes.CDLL("librcl.so")
        rcl.rcl_publisher_is_valid.argtypes = [ctypes.c_void_p]
        rcl.rcl_publisher_is_valid.restype = ctypes.c_bool
        rcl.rcl_publisher_get_topic_name.argtypes = [ctypes.c_void_p]
        rcl.rcl_publisher_get_topic_name.restype = ctypes.c_char_p
        rcl.rcl_publish_serialized_message.argtypes = [
            ctypes.c_void_p, ctypes.POINTER(_Bytes), ctypes.c_void_p]
        rcl.rcl_publish_serialized_message.restype = ctypes.c_int
        # rcl_reset_error is a macro of rcutils'
        rcl.reset_error = ctypes.CDLL("librcutils.so").rcutils_reset_error
        rcl.reset_error.argtypes = []
        rcl.reset_error.restype = None
        _rcl = rcl
    return _rcl


class FeedbackBytes:
    """Publishes one action server's feedback from CDR bytes; ``room``: the largest
    Feedback CDR it takes (the events ring's record)."""

    def __init__(self, handle: Any, publisher: int, room: int) -> None:
        self._handle = handle  # rclpy's server handle: kept alive while publishing
        self._publisher = publisher
        self._publish = _library().rcl_publish_serialized_message
        self._buffer = (ctypes.c_uint8 * (_HEADER + _UUID + room))()
        self._message = _Bytes(ctypes.addressof(self._buffer), 0, len(self._buffer))
        self._ref = ctypes.byref(self._message)
        self._view = memoryview(self._buffer).cast("B")
        self.published = 0

    def publish(self, uuid: bytes, cdr: bytes | memoryview) -> bool:
        """Publish ``cdr`` (a Feedback's CDR) as feedback of the goal ``uuid``; False if
        rcl refused it (or it does not fit)."""
        n = len(cdr)
        if n < _HEADER or n + _UUID > len(self._view):
            return False
        view = self._view
        view[:_HEADER] = cdr[:_HEADER]
        view[_HEADER : _HEADER + _UUID] = uuid
        view[_HEADER + _UUID : _UUID + n] = cdr[_HEADER:]
        self._message.buffer_length = _UUID + n
        with self._handle:  # rclpy's Destroyable: not destroyed during the call
            ret = self._publish(self._publisher, self._ref, None)
        if ret != 0:
            _rcl.reset_error()
            return False
        self.published += 1
        return True


def feedback_bytes(server: Any, room: int) -> FeedbackBytes | None:
    """The byte publisher of an ``rclpy.action.ActionServer``'s feedback, or None where
    its feedback publisher cannot be found and checked (then rclpy publishes messages)."""
    try:
        handle = server._handle
        address = int(handle.pointer)  # rcl_action_server_t *
        rcl = _library()
    except (AttributeError, OSError, TypeError, ValueError):
        return None
    if not address:
        return None
    impl = ctypes.c_void_p.from_address(address).value  # rcl_action_server_impl_t *
    if not impl:
        return None
    publisher = impl + 3 * ctypes.sizeof(ctypes.c_void_p)  # after three rcl_service_t
    if not rcl.rcl_publisher_is_valid(publisher):
        rcl.reset_error()  # the check set rcl's error state: leave none behind
        return None
    topic = rcl.rcl_publisher_get_topic_name(publisher)
    if topic is None or not topic.decode("utf-8", "replace").endswith(FEEDBACK_SUFFIX):
        return None
    return FeedbackBytes(handle, publisher, room)
