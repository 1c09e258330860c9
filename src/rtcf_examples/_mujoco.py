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
