"""A team's ros2_control YAML, read as its controller manager reads it.

ros2_control's ``ros2_control_node`` is given the controllers YAML
(``--params-file controllers.yaml``). Its own section (the node named
``controller_manager``) holds ``update_rate`` and one ``<controller>.type`` per
controller; every other section is a controller's ``ros__parameters``, read by the
controller's node (named after the controller, in the manager's namespace) when the
controller is loaded. A runner given the same files does the same:
``update_rate`` sets its loop's frequency (when it has no ``frequency`` of its own),
``load_controller`` finds the controller's type in :attr:`ControllerSetup.types`, and
the loaded component is configured with :meth:`ControllerSetup.params_for`.

Sections are matched by node name as ROS 2 matches a parameters file's keys: the
name, the full name (with or without its leading '/'), or a pattern with ``*`` and
``**`` (``/**`` for every node). Several matching sections (and several files) are
merged in order, later values winning, as rclpy does.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from .._core._errors import ConfigurationError
from .._core._settings import RunnerSettings
from ._ros_parameters import params_for, params_key_matches, read_sections

__all__ = ["ControllerSetup", "params_key_matches", "read_setup"]


@dataclass
class ControllerSetup:
    """The controller manager ``manager`` (a full node name) as the files configure it."""

    manager: str
    files: tuple[str, ...] = ()
    update_rate: float | None = None
    types: dict[str, str] = field(default_factory=dict)  # controller name -> its type
    # per file, its sections: node key -> ros__parameters (_ros_parameters)
    _sections: list[tuple[str, dict[str, dict[str, Any]]]] = field(default_factory=list)

    def params_for(self, full_name: str) -> dict[str, Any]:
        """The flattened ``ros__parameters`` of node ``full_name`` (a controller)."""
        merged: dict[str, Any] = {}
        for _, sections in self._sections:
            merged.update(params_for(sections, full_name))
        return merged

    def set_frequency(self, settings: RunnerSettings, given: bool, where: str) -> None:
        """``update_rate`` is the loop's frequency when the runner has none of its own
        (``given``); both, and different: a ConfigurationError."""
        if self.update_rate is None:
            return
        if not given:
            settings.frequency = self.update_rate
            settings.notes = [n for n in settings.notes if "no frequency given" not in n]
            settings.validate(f"{where} (update_rate of {', '.join(self.files)})")
        elif settings.frequency != self.update_rate:
            raise ConfigurationError(
                f"{where}: frequency {settings.frequency:g} Hz and the controller manager "
                f"{self.manager}'s update_rate {self.update_rate:g} Hz "
                f"({', '.join(self.files)}) differ; give one of them, or the same value"
            )


def read_setup(paths: Iterable[str], manager: str) -> ControllerSetup:
    """The setup of controller manager ``manager`` (a full name) from parameters files."""
    setup = ControllerSetup(manager=manager, files=tuple(str(p) for p in paths))
    for path in setup.files:
        setup._sections.append((path, read_sections(path)))
    own = setup.params_for(manager)
    rate = own.get("update_rate")
    if rate is not None:
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0:
            raise ConfigurationError(
                f"{', '.join(setup.files)}: {manager}'s update_rate {rate!r} is not a "
                "positive number of Hz"
            )
        setup.update_rate = float(rate)
    for key, value in own.items():
        name, dot, rest = key.partition(".")
        if dot and rest == "type":
            if not isinstance(value, str) or "/" not in value:
                raise ConfigurationError(
                    f"{', '.join(setup.files)}: {manager}'s {key} {value!r} is not a "
                    "controller type such as joint_state_broadcaster/JointStateBroadcaster"
                )
            setup.types[name] = value
    return setup
