"""Controller types by their ros2_control name, the Python way: an entry-point group.

A ros2_control setup names each controller's type as a pluginlib class
(``joint_trajectory_controller/JointTrajectoryController``); the controller manager
finds the plugin that a package declared under that name. Python's equivalent is an
entry point: a package declares, in its ``pyproject.toml``,

    [project.entry-points."rtcf.controllers"]
    "pid_controller/PidController" = "rtcf_controllers:PidController"

and :func:`resolve` finds the class by the type's name, so that third-party packages
add their own controllers to what ``load_controller`` and ``list_controller_types``
know, as pluginlib's do. Nothing is imported until a type is resolved.
"""

from __future__ import annotations

from importlib.metadata import EntryPoint, entry_points

from .._core._errors import ConfigurationError

GROUP = "rtcf.controllers"


def _declared() -> dict[str, EntryPoint]:
    found: dict[str, EntryPoint] = {}
    for ep in entry_points(group=GROUP):
        found.setdefault(ep.name, ep)  # the first distribution that declares a name wins
    return found


def controller_types() -> list[str]:
    """The installed types' names, sorted (what ``list_controller_types`` answers)."""
    return sorted(_declared())


def resolve(type_name: str) -> tuple[str, str]:
    """The ``(module, class)`` that implement ``type_name``, as a launcher would name them.

    An unknown type is a ConfigurationError naming it and what is installed.
    """
    ep = _declared().get(type_name)
    if ep is None:
        known = ", ".join(controller_types()) or "none"
        raise ConfigurationError(
            f"controller type {type_name!r} is not installed (entry points of group "
            f"{GROUP!r}: {known}); install the package that provides it, or declare it "
            f"under [project.entry-points.\"{GROUP}\"] in your package's pyproject.toml"
        )
    module, _, attr = ep.value.partition(":")
    if not module.strip() or not attr.strip():
        raise ConfigurationError(
            f"controller type {type_name!r}: entry point {ep.value!r} is not of the form "
            "'module:Class'"
        )
    return module.strip(), attr.strip()
