"""Errors that rtcf reports to users: one line that names what is at fault."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Location:
    """Where something was written: a file and a 1-based line (None when unknown)."""

    file: str
    line: int | None = None

    def __str__(self) -> str:
        return self.file if self.line is None else f"{self.file}:{self.line}"


class RtcfError(Exception):
    """Base class of every error rtcf raises on bad input or a failing component.

    ``str(error)`` is a single line that names the file and line (when known), the
    component, port or topic at fault, and what to do about it.
    """

    def __init__(self, message: str, *, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line

    def __str__(self) -> str:
        if self.file is None:
            return self.message
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        return f"{where}: {self.message}"


class LaunchError(RtcfError):
    """A launch file is malformed or refers to something that does not exist."""


class ConfigurationError(RtcfError):
    """A runner setting or a component parameter has an invalid value."""


class GraphError(RtcfError):
    """The data-flow graph cannot be built: a cycle, a type mismatch, two producers."""


class LoopError(RtcfError):
    """The loop had to end: a watchdog fired, or the worker was stopped abnormally."""


class ComponentError(RtcfError):
    """A component could not be loaded, or one of its hooks failed or raised."""

    def __init__(
        self,
        message: str,
        *,
        component: str | None = None,
        file: str | None = None,
        line: int | None = None,
    ) -> None:
        super().__init__(message, file=file, line=line)
        self.component = component
