"""joint_trajectory_controller's parameters, read and checked once in ``configure``.

The names, defaults and the checks of the interface combinations are ros2_controllers'
(``joint_trajectory_controller_parameters.yaml``, ``validate_jtc_parameters.hpp``);
what rtcf does not support is refused here, naming the parameter.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ._params import ControllerParameters
from ._tolerances import Tolerances, from_parameters

COMMANDS = ("position", "velocity", "acceleration", "effort")
_STATES = ("position", "velocity", "acceleration")


def _interfaces(p: ControllerParameters, name: str, allowed: tuple[str, ...]) -> list[str]:
    chosen = p.names(name, [], non_empty=True)
    wrong = [i for i in chosen if i not in allowed]
    if wrong:
        raise p._error(name, chosen, "a list of " + ", ".join(allowed))
    return chosen


def _combination(commands: list[str], states: list[str]) -> str | None:
    """Why these interfaces do not go together (ros2_controllers' validators)."""
    c, s = set(commands), set(states)
    if "velocity" in c and len(c) > 1 and "position" not in c:
        return "command 'velocity' goes alone or with 'position'"
    if "acceleration" in c and not {"velocity", "position"} & c:
        return "command 'acceleration' needs 'position' or 'velocity'"
    if "effort" in c and not (len(c) == 1 or c == {"position", "effort"}):
        return "command 'effort' goes alone or with 'position'"
    if "position" not in s:
        return "state_interfaces must list 'position'"
    if "acceleration" in s and "velocity" not in s:
        return "state 'acceleration' needs state 'velocity'"
    if (c in ({"velocity"}, {"effort"}, {"position", "effort"})) and "velocity" not in s:
        return "commands 'velocity' or 'effort' alone need the 'velocity' state interface"
    return None


class Pid:
    """control_toolbox's Pid per joint (p, i, d, integral and output clamps)."""

    def __init__(self, p: ControllerParameters, joints: list[str]) -> None:
        def gains(name: str, default: float) -> np.ndarray:
            return np.array([p.number(f"gains.{j}.{name}", default) for j in joints])

        self.p, self.i, self.d = gains("p", 0.0), gains("i", 0.0), gains("d", 0.0)
        clamp = gains("i_clamp", math.inf)  # the deprecated symmetric one
        self.i_max = np.minimum(gains("i_clamp_max", math.inf), clamp)
        self.i_min = np.maximum(gains("i_clamp_min", -math.inf), -clamp)
        self.u_max, self.u_min = gains("u_clamp_max", math.inf), gains("u_clamp_min", -math.inf)
        self.ff_velocity_scale = gains("ff_velocity_scale", 0.0)
        self.integral = np.zeros(len(joints))
        self._term = np.zeros(len(joints))

    def reset(self) -> None:
        self.integral.fill(0.0)

    def compute(self, error: np.ndarray, error_dot: np.ndarray, dt: float,
                out: np.ndarray) -> None:
        """Adds the PID's command to ``out``."""
        term = self._term
        np.multiply(self.i, error, out=term)
        term *= dt
        self.integral += term
        np.clip(self.integral, self.i_min, self.i_max, out=self.integral)
        np.multiply(self.p, error, out=term)
        term += self.integral
        out += term
        np.multiply(self.d, error_dot, out=term)
        out += term
        np.clip(out, self.u_min, self.u_max, out=out)


@dataclasses.dataclass
class Settings:
    """What the controller's parameters say (docs/controllers.md lists them)."""

    joints: list[str]
    command_interfaces: list[str]
    state_interfaces: list[str]
    allow_partial: bool
    allow_nonzero_end: bool
    from_desired: bool  # interpolate_from_desired_state (or open_loop_control)
    interpolate: bool  # interpolation_method: splines
    feedback_every: int  # iterations between feedback messages
    state_every: int  # iterations between controller_state messages (0: never)
    defaults: Tolerances
    cmd_timeout: float  # 0: off
    pid: Pid | None  # for a lone velocity or effort command
    velocity_error: bool  # which errors ros2_controllers computes (the rest stay 0)
    acceleration_error: bool


def read_settings(component: Any) -> Settings:
    """The settings of ``component`` (an rtcf.Component), or ConfigurationError."""
    p = ControllerParameters(component)
    joints = p.names("joints", [], non_empty=True)
    command_joints = p.names("command_joints", [])
    if command_joints and command_joints != joints:
        raise p._error("command_joints", command_joints,
                       "[] or the joints themselves (a subset is not supported by rtcf)")
    command_interfaces = _interfaces(p, "command_interfaces", COMMANDS)
    state_interfaces = _interfaces(p, "state_interfaces", _STATES)
    problem = _combination(command_interfaces, state_interfaces)
    if problem:
        raise p._error("command_interfaces", command_interfaces,
                       f"interfaces that go together: {problem}")
    for unsupported in ("allow_integration_in_goal_trajectories",
                        "constraints.decelerate_on_cancel"):
        if p.flag(unsupported, False):
            raise p._error(unsupported, True, "false (rtcf does not support it yet)")
    open_loop = p.flag("open_loop_control", False)
    monitor_rate = p.number("action_monitor_rate", 20.0, positive=True)
    state_rate = p.number("state_publish_rate", 50.0)
    defaults = from_parameters(p, joints)
    cmd_timeout = p.number("cmd_timeout", 0.0)
    if 0.0 < cmd_timeout <= defaults.goal_time:
        component.log.warning("cmd_timeout %g s is not above constraints.goal_time %g s: "
                              "ignored", cmd_timeout, defaults.goal_time)
    commands, states = set(command_interfaces), set(state_interfaces)
    use_pid = (commands == {"velocity"} and not open_loop) or commands == {"effort"}
    frequency = component.frequency
    return Settings(
        joints=joints,
        command_interfaces=command_interfaces,
        state_interfaces=state_interfaces,
        allow_partial=p.flag("allow_partial_joints_goal", False),
        allow_nonzero_end=p.flag("allow_nonzero_velocity_at_trajectory_end", False),
        from_desired=p.flag("interpolate_from_desired_state", False) or open_loop,
        interpolate=p.text("interpolation_method", "splines",
                           choices=("splines", "none")) == "splines",
        feedback_every=max(1, round(frequency / monitor_rate)),
        state_every=max(1, round(frequency / state_rate)) if state_rate > 0 else 0,
        defaults=defaults,
        cmd_timeout=cmd_timeout if cmd_timeout > defaults.goal_time else 0.0,
        pid=Pid(p, joints) if use_pid else None,
        velocity_error="velocity" in states and bool({"velocity", "effort"} & commands),
        acceleration_error="acceleration" in states and "acceleration" in commands,
    )
