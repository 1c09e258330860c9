"""Claims of command interfaces per ``joint/interface`` key, and the command mode switch.

A controller claims the command interfaces it writes, by their full names
(``joint1/position``), as ros2_control's controller manager claims them from its
resource manager: two controllers on different joints, or on different interfaces of
one joint, of the same hardware run together; a second claim of a claimed key, or a
claim of a key that no configured hardware exports, is refused with the controller
manager's words (and what rtcf knows besides: the holder, the hardware's state, the
name meant). A switch (controllers activated and deactivated in one request) is
checked as a whole, then each hardware concerned is asked
(``prepare_command_mode_switch``) and told (``perform_command_mode_switch``), and only
then do the claims change: a refused switch changes nothing.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Protocol

from ._controller_references import ControllerReferences
from ._errors import RtcfError
from ._hardware import ReturnType, return_result
from ._lifecycle import ACTIVE, INACTIVE, STATE_LABELS


class Resources(Protocol):
    """What the claims ask of a resource manager (rtcf._core._resource_manager's)."""

    @property
    def command_index(self) -> Mapping[str, int]: ...

    @property
    def state_index(self) -> Mapping[str, int]: ...

    @property
    def command_keys(self) -> Sequence[str]: ...

    @property
    def state_keys(self) -> Sequence[str]: ...

    @property
    def components(self) -> Mapping[str, Any]: ...

    @property
    def references(self) -> ControllerReferences:
        """The chainable controllers' reference interfaces."""
        ...

    def command_interface_exists(self, key: str) -> bool: ...

    def command_interface_is_available(self, key: str) -> bool: ...

    def state_interface_is_available(self, key: str) -> bool: ...

    def hardware_of(self, key: str) -> str: ...

    def command_owners(self) -> Iterable[tuple[Any, Mapping[str, int]]]:
        """Each hardware that is written (actuators, then systems) and its command
        interfaces' indices by key."""
        ...



class ClaimError(RtcfError):
    """A switch of controllers' claims that ros2_control would refuse."""


class InterfaceClaims:
    """Which controller holds which command interface of a resource manager."""

    def __init__(self, resources: Resources, allow_inactive_hardware: bool,
                 logger: Any) -> None:
        self.resources = resources
        self.allow_inactive_hardware = allow_inactive_hardware
        self.logger = logger
        self._holder: dict[str, str] = {}
        self._by_controller: dict[str, tuple[str, ...]] = {}

    # ------------------------------------------------------------------ questions

    def is_claimed(self, key: str) -> bool:
        """ros2_control's ``command_interface_is_claimed``: claimed and available."""
        return key in self._holder and self.resources.command_interface_is_available(key)

    def holder(self, key: str) -> str:
        """The controller that claimed ``key`` ("" if none)."""
        return self._holder.get(key, "")

    def claimed_interfaces(self, controller: str) -> tuple[str, ...]:
        return self._by_controller.get(controller, ())

    def controllers_using(self, hardware: str) -> list[str]:
        """The controllers that hold a command interface of ``hardware`` (to deactivate
        when it fails, as the controller manager does)."""
        return sorted({controller for key, controller in self._holder.items()
                       if self.resources.hardware_of(key) == hardware})

    # ------------------------------------------------------------------- changes

    def claim(self, controller: str, keys: Sequence[str], state_keys: Sequence[str] = ()) -> None:
        """Activate ``controller``'s claim of ``keys`` (a switch of one)."""
        self.switch({controller: keys}, (), {controller: state_keys})

    def release(self, controller: str) -> None:
        """Deactivate ``controller``'s claims (a switch of one)."""
        self.switch({}, (controller,))

    def check(self, activate: Mapping[str, Sequence[str]], deactivate: Iterable[str] = (),
              state_interfaces: Mapping[str, Sequence[str]] | None = None) -> str:
        """Why the controller manager would refuse this switch ("" if it would not):
        ``activate`` maps each controller to the command interfaces it claims,
        ``deactivate`` names controllers whose claims are released in the same switch,
        ``state_interfaces`` the state interfaces each activated one reads."""
        resources = self.resources
        leaving = set(deactivate)
        released = {key for key, holder in self._holder.items() if holder in leaving}
        taken: set[str] = set()
        for controller, keys in activate.items():
            if controller in leaving:
                continue
            for key in keys:
                if not resources.command_interface_is_available(key):
                    return (f"Unable to activate controller '{controller}' since the command "
                            f"interface '{key}' is not available.{self._why(key, 'command')}")
                holder = self._holder.get(key)
                if holder is not None and holder != controller and key not in released:
                    return (f"Unable to activate controller '{controller}' since the command "
                            f"interface '{key}' is currently claimed by another controller. "
                            f"(by '{holder}')")
                if key in taken:
                    return (f"Unable to activate controller '{controller}' since the command "
                            f"interface '{key}' will be used by another controller that is "
                            "being activated.")
                taken.add(key)
            for key in (state_interfaces or {}).get(controller, ()):
                if not resources.state_interface_is_available(key):
                    return (f"Unable to activate controller '{controller}' since the state "
                            f"interface '{key}' is not available.{self._why(key, 'state')}")
        return ""

    def switch(self, activate: Mapping[str, Sequence[str]], deactivate: Iterable[str] = (),
               state_interfaces: Mapping[str, Sequence[str]] | None = None) -> None:
        """Check the switch, ask and tell the hardware, then move the claims; a
        ClaimError (and nothing changed) if it is refused."""
        deactivate = tuple(deactivate)
        problem = self.check(activate, deactivate, state_interfaces)
        if problem:
            raise ClaimError(problem)
        start = [key for controller, keys in activate.items() if controller not in deactivate
                 for key in keys if self._holder.get(key) != controller]
        stop = [key for controller in deactivate for key in self._by_controller.get(controller, ())]
        hardware = self.resources.command_index  # (controllers' references: no mode switch)
        start, stop = [k for k in start if k in hardware], [k for k in stop if k in hardware]
        problem = self._prepare(start, stop)
        if problem:
            raise ClaimError("Could not switch controllers since prepare command mode switch "
                             f"was rejected. ({problem})")
        if not self.perform_command_mode_switch(start, stop):
            raise ClaimError("Could not switch controllers since perform command mode switch "
                             "failed (see the hardware's log)")
        for controller in deactivate:
            for key in self._by_controller.pop(controller, ()):
                if self._holder.get(key) == controller:
                    del self._holder[key]
        for controller, keys in activate.items():
            if controller in deactivate:
                continue
            self._by_controller[controller] = tuple(
                dict.fromkeys((*self._by_controller.get(controller, ()), *keys)))
            for key in keys:
                self._holder[key] = controller

    # --------------------------------------------------------- command mode switch

    def prepare_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        """ros2_control's ``ResourceManager::prepare_command_mode_switch``."""
        return not self._prepare(start, stop)

    def _prepare(self, start: Sequence[str], stop: Sequence[str]) -> str:
        if not start and not stop:
            return ""
        resources = self.resources
        for check, what in ((resources.command_interface_exists, "Not existing"),
                            (resources.command_interface_is_available, "Not available")):
            bad = [key for key in (*start, *stop) if not check(key)]
            if bad:
                problem = (f"Not acceptable command interfaces combination: start "
                           f"{list(start)}, stop {list(stop)}; {what}: {bad}")
                self.logger.error("%s", problem)
                return problem
        problem = ""
        for name, component, starting, stopping in self._per_hardware(start, stop):
            if starting and component.state == INACTIVE and not self.allow_inactive_hardware:
                problem = (f"Component '{name}' is in INACTIVE state, but has start interfaces "
                           f"to switch: {starting}")
                self.logger.warning("%s", problem)
                return problem
            if component.state not in (INACTIVE, ACTIVE):
                problem = (f"Component '{name}' is not in INACTIVE or ACTIVE state, skipping "
                           "the prepare switch")
                self.logger.warning("%s", problem)
                continue
            try:
                result = return_result(
                    component.impl.prepare_command_mode_switch(starting, stopping))
            except Exception as exc:
                problem = (f"Exception of type : {type(exc).__name__} occurred while preparing "
                           f"command mode switch for component '{name}' for the interfaces: "
                           f"start {starting}, stop {stopping} : {exc}")
                self.logger.error("%s", problem)
                continue
            if result is not ReturnType.OK:
                problem = (f"Component '{name}' did not accept command interfaces combination: "
                           f"start {starting}, stop {stopping}")
                self.logger.error("%s", problem)
        return problem

    def perform_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        """ros2_control's ``ResourceManager::perform_command_mode_switch``."""
        if not start and not stop:
            return True
        ok = True
        for name, component, starting, stopping in self._per_hardware(start, stop):
            if starting and component.state == INACTIVE and not self.allow_inactive_hardware:
                self.logger.warning(
                    "Component '%s' is in INACTIVE state, but has start interfaces to switch: "
                    "%s", name, starting)
                return False
            if component.state not in (INACTIVE, ACTIVE):
                self.logger.warning(
                    "Component '%s' is not in INACTIVE or ACTIVE state, skipping the perform "
                    "switch", name)
                ok = False
                continue
            try:
                result = return_result(
                    component.impl.perform_command_mode_switch(starting, stopping))
            except Exception as exc:
                self.logger.error(
                    "Exception of type : %s occurred while performing command mode switch for "
                    "component '%s' for the interfaces: start %s, stop %s : %s",
                    type(exc).__name__, name, starting, stopping, exc)
                result = None
            if result is not ReturnType.OK:
                self.logger.error(
                    "Component '%s' could not perform switch for the command interfaces: start "
                    "%s, stop %s", name, starting, stopping)
                ok = False
        return ok

    def _per_hardware(self, start: Sequence[str], stop: Sequence[str]):  # type: ignore[no-untyped-def]
        """(name, component, its start keys, its stop keys) of each hardware with some,
        actuators before systems, as ros2_control asks them."""
        resources = self.resources
        for component, mine in resources.command_owners():
            starting = [key for key in start if key in mine]
            stopping = [key for key in stop if key in mine]
            if starting or stopping:
                yield component.name, component, starting, stopping

    def _why(self, key: str, kind: str) -> str:
        """What rtcf knows about an unavailable interface, for the refusal."""
        resources = self.resources
        owner = resources.references.owner(key)
        if owner:
            return f" (a reference interface of controller '{owner.lstrip('/')}', not active)"
        hardware = resources.hardware_of(key)
        if hardware and (key in resources.command_index or key in resources.state_index):
            state = resources.components[hardware].state
            return f" (hardware component '{hardware}' is {STATE_LABELS[state]})"
        known = ((*resources.command_keys, *resources.references.keys()) if kind == "command"
                 else resources.state_keys)
        close = difflib.get_close_matches(key, known, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        return f" (no hardware component exports it{hint})"
