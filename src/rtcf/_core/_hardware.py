"""Hardware components in Python: ros2_control Jazzy's hardware interface API.

A hardware component is a class derived from :class:`SystemInterface`,
:class:`ActuatorInterface` or :class:`SensorInterface` (the ``type`` of its
``<ros2_control>`` tag), found by the ``<plugin>`` name of its ``<hardware>`` tag
(:mod:`._hardware_plugins`), and driven by a resource manager
(:mod:`._resource_manager`) as ros2_control's drives its C++ plugins:

* ``on_init(info)`` once, with the tag's :class:`HardwareInfo`; then
  ``on_configure``, ``on_activate``, ``on_deactivate``, ``on_cleanup``, ``on_shutdown``
  and ``on_error`` with the state it leaves (a :class:`LifecycleState`). Each returns a
  :class:`CallbackReturn`; returning None (or True) counts as SUCCESS and False as
  FAILURE, the Python way.
* ``read(time, period)`` in every iteration while inactive or active, ``write(time,
  period)`` while active (a sensor has none). ``time`` and ``period`` are seconds
  (floats). Each returns a :class:`ReturnType`; None (or True) counts as OK, False as
  ERROR. A raised exception is an ERROR too.
* ``prepare_command_mode_switch(start, stop)`` and ``perform_command_mode_switch``
  when controllers claim or release command interfaces (lists of full names).

The interfaces a component has are those its tag lists, exported as Jazzy's default
``on_export_state_interfaces``/``on_export_command_interfaces`` do (a system: joints,
sensors and GPIOs; an actuator: joints; a sensor: the joints' and sensors' states),
with full names ``"<joint, sensor or gpio>/<interface>"``, plus the component's own
("unlisted") ones if it overrides ``export_unlisted_state_interface_descriptions`` or
``export_unlisted_command_interface_descriptions``; overriding
``on_export_state_interfaces``/``on_export_command_interfaces`` replaces the list.

Values. All of a component's states are one float64 array, :attr:`states`, and all its
commands another, :attr:`commands` (layout and initial values: :mod:`._hardware_layout`).
Read and write them by name with Jazzy's accessors (``get_state``, ``set_state``,
``get_command``, ``set_command``), or, in vectorised code, through views that are
slices of those arrays: ``joint_states("position")`` (the position states of the
joints that have one, in the order of ``joints_with_state("position")``),
``joint_commands("velocity")``, ``sensor_states("ft")``, ``gpio_states("io")``,
``gpio_commands("io")``. Take views once (in ``on_configure``), not in every ``read``.

The arrays' contract, for whoever builds the component (a resource manager, a test):
:meth:`~HardwareComponentInterface.bind_values` is called once, after ``on_init`` and
the exports, with two 1-D float64 arrays of ``len(state_names)`` and
``len(command_names)`` values (views into larger buffers are the point: a resource
manager puts every hardware's values in one buffer, and controllers gather and
scatter them by index) or None for arrays of the component's own. The component writes
the initial values into them and from then on keeps these very arrays: never a copy,
never a new one, so that indices into the buffer stay valid for the component's life.
"""

from __future__ import annotations

import enum
import logging
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from ._errors import RtcfError
from ._hardware_layout import (
    InterfaceDescription,
    Layout,
    checked_values,
    descriptions_of,
    layout,
)
from ._lifecycle import STATE_LABELS, UNKNOWN
from ._robot_description import HardwareInfo


class CallbackReturn(enum.IntEnum):
    """What a lifecycle hook returns (rclcpp_lifecycle's, with lifecycle_msgs' numbers)."""

    SUCCESS = 97
    FAILURE = 98
    ERROR = 99


class ReturnType(enum.IntEnum):
    """What ``read``, ``write`` and the command mode switch return
    (``hardware_interface::return_type``)."""

    OK = 0
    ERROR = 1
    DEACTIVATE = 2


class LifecycleState(NamedTuple):
    """A lifecycle state: lifecycle_msgs/State's ``id`` and ``label``."""

    id: int
    label: str

    @classmethod
    def of(cls, state_id: int) -> LifecycleState:
        return cls(state_id, STATE_LABELS[state_id])


class InterfaceNotFoundError(RtcfError, LookupError):
    """A state or command interface the hardware component does not have."""


def callback_result(value: object) -> CallbackReturn | None:
    """A hook's return value as a CallbackReturn (None/True: SUCCESS, False: FAILURE);
    None if it is none of these."""
    if value is None or value is True:
        return CallbackReturn.SUCCESS
    if value is False:
        return CallbackReturn.FAILURE
    if isinstance(value, CallbackReturn):
        return value
    return None


def return_result(value: object) -> ReturnType | None:
    """``read``'s, ``write``'s or a switch's return value as a ReturnType (None/True: OK,
    False: ERROR); None if it is none of these."""
    if value is None or value is True or value is ReturnType.OK:
        return ReturnType.OK
    if value is False:
        return ReturnType.ERROR
    if isinstance(value, ReturnType):
        return value
    return None


class HardwareComponentInterface(ABC):
    """What every hardware component has (ros2_control's ``HardwareComponentInterface``).

    Derive from :class:`SystemInterface`, :class:`ActuatorInterface` or
    :class:`SensorInterface`. The class is built with no arguments, as pluginlib builds
    a plugin; everything it needs arrives in ``on_init``.
    """

    #: the ``<ros2_control type>`` this class implements
    hardware_type = ""

    def __init__(self) -> None:
        self._info: HardwareInfo | None = None
        self._logger: Any = logging.getLogger("rtcf.hardware")
        self._lifecycle_state = LifecycleState.of(UNKNOWN)
        # the interfaces of the description, by kind (filled before on_init runs)
        self.joint_state_interfaces: dict[str, InterfaceDescription] = {}
        self.joint_command_interfaces: dict[str, InterfaceDescription] = {}
        self.sensor_state_interfaces: dict[str, InterfaceDescription] = {}
        self.gpio_state_interfaces: dict[str, InterfaceDescription] = {}
        self.gpio_command_interfaces: dict[str, InterfaceDescription] = {}
        self._state_layout: Layout | None = None
        self._command_layout: Layout | None = None
        self.states: np.ndarray = np.empty(0)
        self.commands: np.ndarray = np.empty(0)
        self._views: dict[tuple[str, str, str], np.ndarray] = {}
        self._bound = False

    # ----------------------------------------------------------- lifecycle (override)

    def on_init(self, info: HardwareInfo) -> CallbackReturn | None:
        """Check and keep what the description says (``info`` is also :attr:`info`).
        The interface descriptions are already parsed when this runs; calling
        ``super().on_init(info)`` is harmless, as in ros2_control."""
        return CallbackReturn.SUCCESS

    def on_configure(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    def on_cleanup(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    def on_shutdown(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    def on_error(self, previous_state: LifecycleState) -> CallbackReturn | None:
        return CallbackReturn.SUCCESS

    @abstractmethod
    def read(self, time: float, period: float) -> ReturnType | None:
        """Read the hardware into :attr:`states` (real-time: no blocking calls)."""

    def prepare_command_mode_switch(
        self, start_interfaces: Sequence[str], stop_interfaces: Sequence[str]
    ) -> ReturnType | None:
        """May these command interfaces start and stop being claimed? Not real-time."""
        return ReturnType.OK

    def perform_command_mode_switch(
        self, start_interfaces: Sequence[str], stop_interfaces: Sequence[str]
    ) -> ReturnType | None:
        """Switch to the new claims (real-time: in the loop, between two iterations)."""
        return ReturnType.OK

    # ------------------------------------------------------------- exports (override)

    def export_unlisted_state_interface_descriptions(self) -> list[InterfaceDescription]:
        """State interfaces of the component's own, beside those of the description."""
        return []

    def export_unlisted_command_interface_descriptions(self) -> list[InterfaceDescription]:
        """Command interfaces of the component's own, beside those of the description."""
        return []

    def on_export_state_interfaces(self) -> list[InterfaceDescription]:
        """Every state interface: the unlisted ones, the joints', sensors' and GPIOs'."""
        return [*self.export_unlisted_state_interface_descriptions(),
                *self.joint_state_interfaces.values(), *self.sensor_state_interfaces.values(),
                *self.gpio_state_interfaces.values()]

    def on_export_command_interfaces(self) -> list[InterfaceDescription]:
        """Every command interface: the unlisted ones, the joints' and GPIOs'."""
        return [*self.export_unlisted_command_interface_descriptions(),
                *self.joint_command_interfaces.values(), *self.gpio_command_interfaces.values()]

    # ------------------------------------------------------------ the framework's calls

    def init(self, info: HardwareInfo, logger: Any = None) -> CallbackReturn | None:
        """Keep ``info``, parse its interface descriptions as Jazzy does for the
        hardware's type, and run ``on_init`` (what the resource manager calls)."""
        self._info = info
        self._logger = logger if logger is not None else logging.getLogger(
            f"rtcf.hardware.{info.name}")
        self.joint_state_interfaces = _by_name(descriptions_of(info.joints, "state_interfaces"))
        if info.type in ("system", "sensor"):
            self.sensor_state_interfaces = _by_name(
                descriptions_of(info.sensors, "state_interfaces"))
        if info.type in ("system", "actuator"):
            self.joint_command_interfaces = _by_name(
                descriptions_of(info.joints, "command_interfaces"))
        if info.type == "system":
            self.gpio_state_interfaces = _by_name(descriptions_of(info.gpios, "state_interfaces"))
            self.gpio_command_interfaces = _by_name(
                descriptions_of(info.gpios, "command_interfaces"))
        return self.on_init(info)

    def export_interfaces(self) -> tuple[Layout, Layout]:
        """Run the export hooks once and fix the layout of the values (the framework's
        call, after ``on_init``): the state and the command layout."""
        info = self.info
        self._state_layout = layout(info, self.on_export_state_interfaces(), "state")
        commands = self.on_export_command_interfaces() if self.hardware_type != "sensor" else []
        self._command_layout = layout(info, commands, "command")
        return self._state_layout, self._command_layout

    def bind_values(
        self, states: np.ndarray | None = None, commands: np.ndarray | None = None
    ) -> None:
        """Take the arrays that hold the values, once (see the module's docstring for
        the contract), and write the initial values into them."""
        if self._state_layout is None or self._command_layout is None:
            self.export_interfaces()
        assert self._state_layout is not None and self._command_layout is not None
        name = self.info.name
        self.states = checked_values(states, len(self._state_layout), "state", name)
        self.commands = checked_values(commands, len(self._command_layout), "command", name)
        self.states[:] = self._state_layout.initial
        self.commands[:] = self._command_layout.initial
        self._views = {}
        for direction, values, lay in (("state", self.states, self._state_layout),
                                       ("command", self.commands, self._command_layout)):
            for (kind, key), where in lay.groups.items():
                self._views[(direction, kind, key)] = values[where]
        self._bound = True

    # ---------------------------------------------------------------- values by name

    @property
    def state_names(self) -> tuple[str, ...]:
        """The state interfaces' full names, in the order of :attr:`states`."""
        return self._exported("state").names

    @property
    def command_names(self) -> tuple[str, ...]:
        """The command interfaces' full names, in the order of :attr:`commands`."""
        return self._exported("command").names

    @property
    def state_index(self) -> Mapping[str, int]:
        return self._exported("state").index

    @property
    def command_index(self) -> Mapping[str, int]:
        return self._exported("command").index

    def has_state(self, name: str) -> bool:
        return name in self._exported("state").index

    def has_command(self, name: str) -> bool:
        return name in self._exported("command").index

    def get_state(self, name: str) -> float:
        return float(self.states[self._position("state", name)])

    def set_state(self, name: str, value: float) -> None:
        self.states[self._position("state", name)] = value

    def get_command(self, name: str) -> float:
        return float(self.commands[self._position("command", name)])

    def set_command(self, name: str, value: float) -> None:
        self.commands[self._position("command", name)] = value

    # ----------------------------------------------------------- views for numpy code

    def joint_states(self, interface: str) -> np.ndarray:
        """The ``interface`` states of the joints that have one: a view."""
        return self._view("state", "joint", interface)

    def joint_commands(self, interface: str) -> np.ndarray:
        """The ``interface`` commands of the joints that have one: a view."""
        return self._view("command", "joint", interface)

    def joints_with_state(self, interface: str) -> tuple[str, ...]:
        """The joints of :meth:`joint_states`, in its order (empty if none)."""
        return tuple(self._exported("state").members.get(("joint", interface), ()))

    def joints_with_command(self, interface: str) -> tuple[str, ...]:
        return tuple(self._exported("command").members.get(("joint", interface), ()))

    def sensor_states(self, sensor: str) -> np.ndarray:
        """A sensor's states, in the order of its ``<state_interface>`` tags: a view."""
        return self._view("state", "sensor", sensor)

    def sensor_commands(self, sensor: str) -> np.ndarray:
        """A sensor's commands (only where the component exports some): a view."""
        return self._view("command", "sensor", sensor)

    def gpio_states(self, gpio: str) -> np.ndarray:
        return self._view("state", "gpio", gpio)

    def gpio_commands(self, gpio: str) -> np.ndarray:
        return self._view("command", "gpio", gpio)

    # ------------------------------------------------------------------ information

    @property
    def info(self) -> HardwareInfo:
        """The ``<ros2_control>`` tag this component was made from."""
        if self._info is None:
            raise RuntimeError(f"{type(self).__name__}: on_init has not run yet")
        return self._info

    @property
    def name(self) -> str:
        return self.info.name

    @property
    def logger(self) -> Any:
        """The component's logger (``debug``, ``info``, ``warning``, ``error``)."""
        return self._logger

    @property
    def lifecycle_state(self) -> LifecycleState:
        return self._lifecycle_state

    # Jazzy's names
    def get_hardware_info(self) -> HardwareInfo:
        return self.info

    def get_name(self) -> str:
        return self.info.name

    def get_group_name(self) -> str:
        return self.info.group

    def get_logger(self) -> Any:
        return self._logger

    def get_lifecycle_state(self) -> LifecycleState:
        return self._lifecycle_state

    def set_lifecycle_state(self, state: LifecycleState) -> None:
        """The framework's: the state the component is in now."""
        self._lifecycle_state = state

    # --------------------------------------------------------------------- internals

    def _exported(self, direction: str) -> Layout:
        found = self._state_layout if direction == "state" else self._command_layout
        if found is None:
            raise RuntimeError(
                f"{type(self).__name__}: its interfaces are not exported yet (values exist "
                "from on_configure on)")
        return found

    def _position(self, direction: str, name: str) -> int:
        try:
            return self._exported(direction).index[name]
        except KeyError:
            raise InterfaceNotFoundError(
                f"The requested {direction} interface not found: '{name}' in hardware "
                f"component: '{self.info.name}'.") from None

    def _view(self, direction: str, kind: str, key: str) -> np.ndarray:
        try:
            return self._views[(direction, kind, key)]
        except KeyError:
            if not self._bound:
                raise RuntimeError(
                    f"{type(self).__name__}: values are not bound yet (they are from "
                    "on_configure on)") from None
            have = sorted(k for d, knd, k in self._views if d == direction and knd == kind)
            raise InterfaceNotFoundError(
                f"hardware component '{self.info.name}' has no {kind} {direction} "
                f"interfaces for '{key}' (it has: {', '.join(have) or 'none'})") from None


class SystemInterface(HardwareComponentInterface):
    """A hardware component with joints, sensors and GPIOs, read and written
    (``<ros2_control type="system">``)."""

    hardware_type = "system"

    def write(self, time: float, period: float) -> ReturnType | None:
        """Write :attr:`commands` to the hardware (real-time: no blocking calls)."""
        return ReturnType.OK


class ActuatorInterface(HardwareComponentInterface):
    """One actuator: joints' commands and states (``<ros2_control type="actuator">``)."""

    hardware_type = "actuator"

    def write(self, time: float, period: float) -> ReturnType | None:
        """Write :attr:`commands` to the hardware (real-time: no blocking calls)."""
        return ReturnType.OK


class SensorInterface(HardwareComponentInterface):
    """A sensor: states only, never written (``<ros2_control type="sensor">``)."""

    hardware_type = "sensor"


INTERFACE_TYPES: dict[str, type[HardwareComponentInterface]] = {}
INTERFACE_TYPES["system"] = SystemInterface  # type: ignore[type-abstract]
INTERFACE_TYPES["actuator"] = ActuatorInterface  # type: ignore[type-abstract]
INTERFACE_TYPES["sensor"] = SensorInterface  # type: ignore[type-abstract]


def _by_name(descriptions: list[InterfaceDescription]) -> dict[str, InterfaceDescription]:
    return {d.name: d for d in descriptions}
