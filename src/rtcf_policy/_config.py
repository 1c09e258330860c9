"""A policy's deployment configuration: what the observation is made of, what the action
means, and the PD stage's gains, read from YAML with the field names of legged_gym's,
unitree_rl_gym's and IsaacLab's deploy configurations where they have one.

Every error is a :class:`rtcf.ConfigurationError` of one line that names the file and
the term (or field) and says what to give instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

import rtcf

# the fields of a deploy configuration this reader knows (others are an error: a typo
# must not pass silently), with unitree_rl_gym's names beside ours
_TOP = {
    "model", "policy_path", "joints", "observation", "action", "clip_observations",
    "clip_actions", "action_scale", "default_angles", "kps", "kds", "num_obs",
    "num_actions", "control_dt", "control_decimation", "simulation_dt", "trained_delay",
}
_TERM = {"name", "port", "index", "size", "scale", "offset", "clip", "history", "default",
         "last_action"}
_ACTION = {"port", "scale", "offset", "clip"}


@dataclass
class Term:
    """One observation term: ``size`` numbers, ``history`` times (oldest first)."""

    name: str
    port: str  # the input port it reads ("": the previous action)
    size: int
    index: np.ndarray | None  # which elements of the port's array (None: all)
    scale: np.ndarray  # per element: (value - offset) * scale, then clipped
    offset: np.ndarray
    low: np.ndarray
    high: np.ndarray
    history: int = 1
    default: np.ndarray | None = None  # the value before the port has one (cmd_init)

    @property
    def width(self) -> int:
        """How many numbers of the observation it fills."""
        return self.size * self.history


@dataclass
class ActionSpec:
    """The model's output: ``target = clip(raw, -clip, clip) * scale + offset``."""

    port: str
    size: int
    scale: np.ndarray
    offset: np.ndarray  # the default joint positions
    clip: float


@dataclass
class PolicyConfig:
    """A whole configuration, as :func:`load_config` read it."""

    path: str  # the YAML file (for messages)
    model: str  # the ONNX file, absolute
    joints: list[str]
    terms: list[Term]
    action: ActionSpec
    clip_observations: float
    kps: np.ndarray | None = None
    kds: np.ndarray | None = None
    control_dt: float | None = None  # the policy's period in training [s]
    trained_delay: float | None = None  # the action delay it was trained with [s]
    simulation_dt: float | None = None  # the physics step it was trained at [s]
    control_decimation: float | None = None  # control_dt = this x simulation_dt
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def num_obs(self) -> int:
        return sum(t.width for t in self.terms)

    def describe_terms(self) -> str:
        """The terms and their widths: ``cart (1) + pole (1) + last_action (1 x 2) = 4``."""
        parts = [f"{t.name} ({t.size}{f' x {t.history}' if t.history > 1 else ''})"
                 for t in self.terms]
        return f"{' + '.join(parts)} = {self.num_obs}"


def load_config(path: str, model: str = "") -> PolicyConfig:
    """Read the configuration at ``path``; ``model`` (if given) replaces its model."""
    try:
        with open(path) as f:
            raw = yaml.safe_load(f)
    except OSError as exc:
        raise rtcf.ConfigurationError(f"policy configuration {path}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise rtcf.ConfigurationError(
            f"policy configuration {path}: not YAML: {str(exc).splitlines()[0]}"
        ) from None
    return parse_config(raw, path, model)


def parse_config(raw: Any, path: str, model: str = "") -> PolicyConfig:
    """A configuration from its YAML value (``path`` for messages and relative files)."""

    def fail(what: str) -> rtcf.ConfigurationError:
        return rtcf.ConfigurationError(f"policy configuration {path}: {what}")

    if not isinstance(raw, dict):
        raise fail("must be a mapping (model, observation, action, ...)")
    unknown = sorted(set(raw) - _TOP)
    if unknown:
        raise fail(f"unknown field {unknown[0]!r}; the fields are {', '.join(sorted(_TOP))}")
    base = Path(path).parent
    model = model or str(raw.get("model") or raw.get("policy_path") or "")
    if not model:
        raise fail("no model: give model: FILE.onnx (relative to this file)")
    model_path = str((base / model) if not Path(model).is_absolute() else Path(model))
    joints = [str(j) for j in raw.get("joints", [])]
    clip_obs = _number(raw.get("clip_observations", math.inf), "clip_observations", fail)
    terms_raw = raw.get("observation")
    if not isinstance(terms_raw, list) or not terms_raw:
        raise fail("observation must be a list of terms (name, port, scale, ...)")
    action_raw = raw.get("action", {})
    if not isinstance(action_raw, dict):
        raise fail("action must be a mapping (port, scale, offset, clip)")
    if set(action_raw) - _ACTION:
        bad = sorted(set(action_raw) - _ACTION)[0]
        raise fail(f"action: unknown field {bad!r}; the fields are {', '.join(sorted(_ACTION))}")
    size = int(raw.get("num_actions", 0)) or len(joints) or _length(
        action_raw.get("offset", raw.get("default_angles")), 0) or 1
    action = ActionSpec(
        port=str(action_raw.get("port", "action")),
        size=size,
        scale=_vector(action_raw.get("scale", raw.get("action_scale", 1.0)), size,
                      "action.scale", fail),
        offset=_vector(action_raw.get("offset", raw.get("default_angles", 0.0)), size,
                       "action.offset (default_angles)", fail),
        clip=_number(action_raw.get("clip", raw.get("clip_actions", math.inf)),
                     "action.clip (clip_actions)", fail),
    )
    terms = [_term(t, k, size, fail) for k, t in enumerate(terms_raw)]
    names = [t.name for t in terms]
    if len(set(names)) != len(names):
        raise fail(f"two observation terms named {next(n for n in names if names.count(n) > 1)!r}")
    config = PolicyConfig(
        path=path, model=model_path, joints=joints, terms=terms, action=action,
        clip_observations=clip_obs,
        kps=None if "kps" not in raw else _vector(raw["kps"], size, "kps", fail),
        kds=None if "kds" not in raw else _vector(raw["kds"], size, "kds", fail),
        control_dt=_optional(raw, "control_dt", fail),
        trained_delay=_optional(raw, "trained_delay", fail, zero=True),
        simulation_dt=_optional(raw, "simulation_dt", fail),
    )
    decimation = _optional(raw, "control_decimation", fail)
    if config.control_dt is None and decimation is not None and config.simulation_dt:
        config.control_decimation = decimation
        config.control_dt = decimation * config.simulation_dt
    declared = raw.get("num_obs")
    if declared is not None and int(declared) != config.num_obs:
        raise fail(f"num_obs is {declared} but the terms make {config.describe_terms()}")
    return config


def _term(raw: Any, k: int, actions: int, fail: Any) -> Term:
    if not isinstance(raw, dict) or "name" not in raw:
        raise fail(f"observation term {k + 1} must be a mapping with a name")
    name = str(raw["name"])
    unknown = sorted(set(raw) - _TERM)
    if unknown:
        raise fail(f"term {name!r}: unknown field {unknown[0]!r}; the fields are "
                   f"{', '.join(sorted(_TERM))}")
    last_action = bool(raw.get("last_action", False))
    port = "" if last_action else str(raw.get("port", ""))
    if not last_action and not port:
        raise fail(f"term {name!r}: give the input port it reads (port: NAME), or "
                   "last_action: true")
    index = None
    if raw.get("index") is not None:
        index = np.array(raw["index"], dtype=np.intp).reshape(-1)
        if index.size == 0 or (index < 0).any():
            raise fail(f"term {name!r}: index must list element numbers from 0")
    default = None
    if raw.get("default") is not None:
        default = np.array(raw["default"], dtype=np.float64).reshape(-1)
    if last_action:
        size = actions
    elif index is not None:
        size = int(index.size)
    elif "size" in raw:
        size = int(raw["size"])
    elif default is not None:
        size = int(default.size)
    else:
        raise fail(f"term {name!r}: give index, size or default (how many numbers it reads "
                   f"from port {port!r})")
    if size < 1:
        raise fail(f"term {name!r}: its size must be at least 1")
    if default is not None and default.size != size:
        raise fail(f"term {name!r}: default has {default.size} numbers, the term {size}")
    history = int(raw.get("history", 1))
    if history < 1:
        raise fail(f"term {name!r}: history must be 1 or more steps")
    clip = raw.get("clip", math.inf)
    if isinstance(clip, (list, tuple)) and len(clip) == 2:
        low = _vector(clip[0], size, f"term {name!r}: clip", fail)
        high = _vector(clip[1], size, f"term {name!r}: clip", fail)
    else:
        high = _vector(clip, size, f"term {name!r}: clip", fail)
        low = -high
    if (low > high).any():
        raise fail(f"term {name!r}: clip's low end is above its high end")
    return Term(
        name=name, port=port, size=size, index=index,
        scale=_vector(raw.get("scale", 1.0), size, f"term {name!r}: scale", fail),
        offset=_vector(raw.get("offset", 0.0), size, f"term {name!r}: offset", fail),
        low=low, high=high, history=history, default=default,
    )


def _vector(value: Any, n: int, what: str, fail: Any) -> np.ndarray:
    """One number for all n, or a list of n."""
    try:
        array = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise fail(f"{what} is {value!r}: give a number or a list of {n}") from None
    if array.size == 1:
        array = np.full(n, array[0])
    if array.size != n or np.isnan(array).any():
        raise fail(f"{what} is {value!r}: give a number or a list of {n}")
    return array


def _length(value: Any, default: int) -> int:
    return len(value) if isinstance(value, (list, tuple)) else default


def _number(value: Any, what: str, fail: Any, zero: bool = False) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise fail(f"{what} is {value!r}: give a number") from None
    if not (number >= 0 if zero else number > 0):
        raise fail(f"{what} is {value!r}: give a number {'of 0 or more' if zero else 'above 0'}")
    return number


def _optional(raw: dict[str, Any], key: str, fail: Any, zero: bool = False) -> float | None:
    return None if raw.get(key) is None else _number(raw[key], key, fail, zero)
