"""What the examples' MuJoCo hardware components share: the model they load (a
parameter, else one shipped as package data), and how many of its timesteps make one
of the component's periods.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from typing import Any

import rtcf


def shipped_model(name: str) -> str:
    """The path of an MJCF model shipped in rtcf_examples/models (package data)."""
    return str(resources.files("rtcf_examples").joinpath("models", name))


@dataclass
class Simulation:
    """A loaded model: ``mujoco`` (the module), ``model``, ``data``, where it came from
    (``path``) and the timesteps per period of the component (``steps``)."""

    mujoco: Any
    model: Any
    data: Any
    path: str
    steps: int


def load_simulation(component: rtcf.Component, default_model: str) -> Simulation:
    """Load ``~model`` (default: the shipped ``default_model``) for ``component``, in
    ``configure``. Its timestep must divide the component's period; anything else is
    refused with both numbers."""
    name = type(component).__name__
    try:
        import mujoco
    except ImportError:
        raise rtcf.ConfigurationError(
            f"{name} needs the mujoco package: pip install 'rtcf[mujoco]'"
        ) from None
    path = str(component.params.get("~model", "") or shipped_model(default_model))
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except (ValueError, OSError) as exc:
        raise rtcf.ConfigurationError(f"~model {path}: {exc}") from None
    timestep = float(model.opt.timestep)
    steps = component.period / timestep
    if abs(steps - round(steps)) > 1e-6 or round(steps) < 1:
        raise rtcf.ConfigurationError(
            f"~model {path}: its timestep {timestep * 1e3:g} ms does not divide this "
            f"component's period {component.period * 1e3:g} ms; set <option timestep> in "
            "the model, or the loop's frequency or the component's rate"
        )
    return Simulation(mujoco, model, mujoco.MjData(model), path, round(steps))


def actuator_limits(model: Any, actuators: Any, command: str) -> list[rtcf.JointLimits]:
    """The limits a real drive would have, as the model gives them, per actuator: its
    joint's ``range`` (positions) and its control range as the ``command`` interface's
    magnitude (a torque motor's ``effort``, a velocity servo's ``velocity``): the
    smaller side of ``ctrlrange``, where the model limits it. The framework clamps the
    hardware's commands to them (docs/hardware-limits.md)."""
    limits = []
    for i in actuators:
        joint = int(model.actuator_trnid[i, 0])
        fields: dict[str, float] = {}
        if model.jnt_limited[joint]:
            fields["min_position"], fields["max_position"] = map(float, model.jnt_range[joint])
        lo, hi = map(float, model.actuator_ctrlrange[i])
        if model.actuator_ctrllimited[i] and lo < 0.0 < hi:
            fields[{"effort": "max_effort", "velocity": "max_velocity"}[command]] = min(-lo, hi)
        limits.append(rtcf.JointLimits(**fields))
    return limits
