"""Closing: the ``with`` statement of an object that holds something until close().

A Ring and a Mailbox (:mod:`rtcf._core._rings`) hold views into a buffer, a Segment
(:mod:`rtcf._runtime._shm`) a mapping and a descriptor; each lets go in its close(),
and ``with obj:`` calls it on the way out. Written once here rather than the same
__enter__ and __exit__ in each class.
"""

from __future__ import annotations

from typing import TypeVar

_C = TypeVar("_C", bound="Closing")


class Closing:
    """A class with close() that is its own context manager (no state of its own)."""

    __slots__ = ()  # adds no __dict__ to the slotted classes below it

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self: _C) -> _C:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
