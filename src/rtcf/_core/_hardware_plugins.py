"""Hardware plugins by their ``<plugin>`` name, the Python way: an entry-point group.

A ``<ros2_control>`` tag names its hardware as a pluginlib class
(``<plugin>mock_components/GenericSystem</plugin>``); ros2_control's resource manager
finds the plugin that a package declared under that name. Python's equivalent is an
entry point: a package declares, in its ``pyproject.toml``,

    [project.entry-points."rtcf.hardware_interfaces"]
    "my_robot/MyRobotSystem" = "my_robot.hardware:MyRobotSystem"

and :func:`load_hardware_class` finds the class by the tag's plugin name. rtcf's own
(``mock_components/GenericSystem``, and the examples' ``rtcf_examples/MujocoSystem``,
which the same distribution ships) are declared the same way in rtcf's pyproject.toml,
and known here too, so that they are found when rtcf runs from its source tree.

As a Python-only convenience, ``<plugin>`` may also name the class directly:
``my_robot.hardware:MyRobotSystem`` or ``my_robot.hardware.MyRobotSystem`` (no ``/``).
Nothing is imported until a plugin is loaded.
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points

from ._errors import ConfigurationError
from ._hardware import INTERFACE_TYPES, HardwareComponentInterface
from ._robot_description import HardwareInfo

GROUP = "rtcf.hardware_interfaces"

# rtcf's own, as pyproject.toml declares them (a test keeps the two the same)
BUILTIN = {
    "mock_components/GenericSystem": "rtcf._core._generic_system:GenericSystem",
    "rtcf_examples/MujocoSystem": "rtcf_examples._mujoco_system:MujocoSystem",
    # shipped with rtcf, imported only when a description names it (needs rtcf[canopen])
    "rtcf_canopen/Cia402System": "rtcf_canopen:Cia402System",
}


def declared_plugins() -> dict[str, str]:
    """Every plugin name known, with its ``module:Class``: rtcf's own, then the
    installed entry points of :data:`GROUP` (the first that declares a name wins)."""
    found = dict(BUILTIN)
    for ep in entry_points(group=GROUP):
        found.setdefault(ep.name, ep.value)
    return found


def hardware_plugins() -> list[str]:
    """The plugin names known, sorted."""
    return sorted(declared_plugins())


def load_hardware_class(info: HardwareInfo) -> type[HardwareComponentInterface]:
    """The class of ``info``'s hardware plugin, checked against its ``type``.

    A plugin that is not found, cannot be imported or is not a hardware interface of
    the tag's type is a ConfigurationError of one line that names the hardware, the
    plugin and what to do."""
    plugin = info.hardware_plugin_name.strip()
    where = f"hardware '{info.name}' (<plugin>{plugin}</plugin>)"
    base = INTERFACE_TYPES[info.type]
    declared = declared_plugins()
    target = declared.get(plugin)
    if target is None and "/" not in plugin and (":" in plugin or "." in plugin):
        target = plugin if ":" in plugin else ":".join(plugin.rsplit(".", 1))
    if target is None:
        raise ConfigurationError(
            f"{where}: According to the loaded plugin descriptions the class {plugin} with "
            f"base class type hardware_interface::{base.__name__} does not exist. Declared "
            f"types are {' '.join(sorted(declared))}. Install the package that declares it "
            f"under the entry point group '{GROUP}', declare it in your package's "
            f"pyproject.toml ([project.entry-points.\"{GROUP}\"] \"{plugin}\" = "
            "\"module:Class\"), or write <plugin>module:Class</plugin>")
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name.strip())
    except ImportError as exc:
        raise ConfigurationError(
            f"{where}: cannot import module '{module_name.strip()}' ({target}): {exc}") from None
    cls = module
    for part in attr.strip().split("."):
        cls = getattr(cls, part, None)  # type: ignore[assignment]
        if cls is None:
            raise ConfigurationError(
                f"{where}: module '{module_name.strip()}' has no class '{attr.strip()}'")
    if not (isinstance(cls, type) and issubclass(cls, HardwareComponentInterface)):
        raise ConfigurationError(
            f"{where}: {target} is not a hardware interface: derive it from "
            f"rtcf.{base.__name__}")
    if not issubclass(cls, base):
        raise ConfigurationError(
            f"{where}: {target} is a {cls.hardware_type or 'hardware'} interface, but the "
            f"<ros2_control> tag's type is '{info.type}': derive it from rtcf.{base.__name__} "
            "or change the tag's type")
    return cls
