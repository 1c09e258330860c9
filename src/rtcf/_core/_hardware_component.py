"""One hardware component's lifecycle, as ros2_control Jazzy's ``HardwareComponent``.

The resource manager holds one :class:`HardwareComponent` per ``<ros2_control>`` tag:
the plugin's object (``impl``), its lifecycle state and its read/write timing. The
transitions follow ``hardware_component.cpp``:

=============  ============  ==========================================================
transition     from          hook result: SUCCESS / FAILURE / ERROR
=============  ============  ==========================================================
initialize     unknown       unconfigured / finalized / finalized
configure      unconfigured  inactive / unconfigured / error processing
cleanup        inactive      unconfigured / error processing / error processing
activate       inactive      active / inactive / error processing
deactivate     active        inactive / active / error processing
shutdown       any but       finalized / error processing / error processing
               finalized
error          any but       ``on_error``: unconfigured / finalized / finalized
               unconfigured
=============  ============  ==========================================================

A transition asked for in another state does nothing. A hook that raises changes
nothing, and the transition fails (ros2_control catches the exception in its resource
manager and logs it; so does rtcf, with its words). A hook that returns something
other than a CallbackReturn, None or a bool is an ERROR.

``read`` runs while inactive or active, ``write`` while active (never for a sensor):
an ERROR (returned or raised) takes the component through ``error`` at once, as in
Jazzy; what the caller does next (its group, its interfaces, DEACTIVATE) is the
resource manager's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ._hardware import (
    CallbackReturn,
    HardwareComponentInterface,
    LifecycleState,
    ReturnType,
    callback_result,
    return_result,
)
from ._lifecycle import ACTIVE, FINALIZED, INACTIVE, UNCONFIGURED, UNKNOWN
from ._robot_description import HardwareInfo

_OK, _ERROR = ReturnType.OK, ReturnType.ERROR


class HardwareComponent:
    """A loaded hardware plugin and its lifecycle (see the module's docstring)."""

    def __init__(self, impl: HardwareComponentInterface, info: HardwareInfo, rw_rate: int,
                 logger: Any) -> None:
        self.impl = impl
        self.info = info
        self.name = info.name
        self.group = info.group
        self.is_sensor = info.type == "sensor"
        self.rw_rate = rw_rate
        self.logger = logger
        self.state = UNKNOWN
        self.last_failure = ""  # what the last hook that raised said (for the error)
        self.last_read_time = math.nan
        self.last_write_time = math.nan
        # bound once: the loop calls these
        self._read = impl.read
        self._write = getattr(impl, "write", None)

    # -------------------------------------------------------------------- lifecycle

    def _set(self, state: int) -> int:
        self.state = state
        self.impl.set_lifecycle_state(LifecycleState.of(state))
        return state

    def _hook(self, what: str, hook: Callable[..., object], *args: object) -> CallbackReturn | None:
        """The hook's result, or None if it raised (logged with ros2_control's words)."""
        try:
            value = hook(*args)
        except Exception as exc:  # a plugin's failure, reported, not propagated
            self.last_failure = f"{type(exc).__name__}: {exc}"
            self.logger.error(
                "Exception of type : %s occurred while %s hardware '%s': %s",
                type(exc).__name__, what, self.name, exc)
            return None
        result = callback_result(value)
        if result is None:
            self.logger.error(
                "hardware '%s': %s returned %r, not a CallbackReturn (or None, True, False)",
                self.name, getattr(hook, "__name__", what), value)
            return CallbackReturn.ERROR
        return result

    def initialize(self) -> int:
        if self.state == UNKNOWN:
            result = self._hook("initializing", self.impl.init, self.info, self.logger)
            if result is None:
                return self.state
            self._set(UNCONFIGURED if result == CallbackReturn.SUCCESS else FINALIZED)
        return self.state

    def _transition(self, what: str, hook: Callable[..., object], outcomes: tuple[int, int]) -> int:
        result = self._hook(what, hook, LifecycleState.of(self.state))
        if result is None:
            return self.state
        if result == CallbackReturn.SUCCESS:
            return self._set(outcomes[0])
        if result == CallbackReturn.FAILURE and outcomes[1] >= 0:
            return self._set(outcomes[1])
        return self.error()

    def configure(self) -> int:
        if self.state != UNCONFIGURED:
            return self.state
        return self._transition("configuring", self.impl.on_configure, (INACTIVE, UNCONFIGURED))

    def cleanup(self) -> int:
        if self.state != INACTIVE:
            return self.state
        return self._transition("cleaning up", self.impl.on_cleanup, (UNCONFIGURED, -1))

    def activate(self) -> int:
        self.last_read_time = self.last_write_time = math.nan
        if self.state != INACTIVE:
            return self.state
        return self._transition("activating", self.impl.on_activate, (ACTIVE, INACTIVE))

    def deactivate(self) -> int:
        if self.state != ACTIVE:
            return self.state
        return self._transition("deactivating", self.impl.on_deactivate, (INACTIVE, ACTIVE))

    def shutdown(self) -> int:
        if self.state in (UNKNOWN, FINALIZED):
            return self.state
        return self._transition("shutting down", self.impl.on_shutdown, (FINALIZED, -1))

    def error(self) -> int:
        """Error processing: ``on_error``; unconfigured if it succeeds, else finalized.
        Once only: a hardware whose read failed, and then its group, is not processed
        again (nor one already finalized)."""
        if self.state in (UNKNOWN, UNCONFIGURED, FINALIZED):
            return self.state
        result = self._hook("handling an error of", self.impl.on_error,
                            LifecycleState.of(self.state))
        return self._set(UNCONFIGURED if result == CallbackReturn.SUCCESS else FINALIZED)

    # ------------------------------------------------------------------ read, write

    def read(self, time: float, period: float) -> ReturnType:
        """The plugin's ``read`` if inactive or active; an ERROR goes through ``error``."""
        state = self.state
        if state != ACTIVE and state != INACTIVE:
            self.last_read_time = time
            return _OK
        result = self._called(self._read, "read", time, period)
        self.last_read_time = time
        return result

    def write(self, time: float, period: float) -> ReturnType:
        """The plugin's ``write`` if active (never for a sensor); an ERROR goes through
        ``error``, a DEACTIVATE is returned for the resource manager to act on."""
        if self.is_sensor or self._write is None:
            return _OK
        if self.state != ACTIVE:
            if self.state != INACTIVE:
                self.last_write_time = time
            return _OK
        result = self._called(self._write, "write", time, period)
        self.last_write_time = time
        return result

    def _called(self, call: Callable[[float, float], object], what: str, time: float,
                period: float) -> ReturnType:
        """The plugin's read or write and what it returned (None: OK; raised: ERROR,
        logged in ros2_control's words); an ERROR goes through ``error``."""
        try:
            value = call(time, period)
        except Exception as exc:
            self.logger.error(
                "Exception of type : %s thrown during %s of the component '%s': %s",
                type(exc).__name__, what, self.name, exc)
            value = _ERROR
        result = _OK if value is None or value is _OK else (return_result(value) or _ERROR)
        if result is _ERROR:
            self.error()
        return result

    def due(self, time: float, last: float, update_rate: int) -> float:
        """The period to pass if a component with its own ``rw_rate`` is due at ``time``
        (ros2_control's choice: now, if that is nearer its rate than the next
        iteration), or NaN if not due."""
        rate = self.rw_rate
        actual = 1.0 / rate if math.isnan(last) else time - last
        error_now = abs(actual * rate - 1.0)
        error_if_skipped = abs((actual + 1.0 / update_rate) * rate - 1.0)
        return actual if error_now <= error_if_skipped else math.nan
