"""joint_trajectory_controller's parameters, read and checked once in ``configure``.

The names, defaults and the checks of the interface combinations are ros2_controllers'
(``joint_trajectory_controller_parameters.yaml``, ``validate_jtc_parameters.hpp``);
what rtcf does not support is refused here, naming the parameter.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction
from typing import Any

import numpy as np

from ._limits import JointLimits, read_limits
from ._params import ControllerParameters
from ._pid import Gains, Pid
from ._tolerances import Tolerances, from_parameters

COMMANDS = ("position", "velocity", "acceleration", "effort")
_STATES = ("position", "velocity", "acceleration")


def _interfaces(p: ControllerParameters, name: str, allowed: tuple[str, ...]) -> list[str]:
    chosen = p.names(name, [], non_empty=True)
    wrong = [i for i in chosen if i not in allowed]
    if wrong:
        raise p.error(name, chosen, "a list of " + ", ".join(allowed))
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


class Pids:
    """control_toolbox's Pid per joint (``gains.<joint>.*``, as pid_controller reads
    them), and JTC's own ``gains.<joint>.ff_velocity_scale``."""

    def __init__(self, p: ControllerParameters, joints: list[str]) -> None:
        self.pids = [Pid(Gains.read(p, j)) for j in joints]
        self.ff_velocity_scale = np.array(
            [p.number(f"gains.{j}.ff_velocity_scale", 0.0) for j in joints])

    def reset(self) -> None:
        for pid in self.pids:
            pid.reset()

    def compute(self, error: np.ndarray, error_dot: np.ndarray, dt: float,
                out: np.ndarray) -> None:
        """Adds each joint's PID command to ``out``."""
        for j, pid in enumerate(self.pids):
            out[j] += pid.compute_with_rate(float(error[j]), float(error_dot[j]), dt)


@dataclasses.dataclass(frozen=True)
class Cadence:
    """A publication at ``rate`` Hz from a controller that runs at ``frequency`` Hz: in
    its run ``k`` when ``floor(k * rate / frequency)`` steps (run 0 included). Where the
    period is no whole number of runs (20 Hz from 250 Hz: 12.5), the runs apart
    alternate (13, 12, 13, ...) and the rate is exact on average, as a ROS timer at that
    rate firing between the controller's updates would be; rounding to one whole
    number of runs would publish at 20.8 Hz."""

    num: int
    den: int

    @classmethod
    def of(cls, rate: float, frequency: float) -> Cadence:
        ratio = Fraction(rate).limit_denominator(10**6) / Fraction(frequency).limit_denominator(
            10**6)
        return cls(ratio.numerator, ratio.denominator)

    def due(self, run: int) -> bool:
        """Whether the controller's ``run``-th run publishes (integers only: in the loop)."""
        return run == 0 or (run * self.num) // self.den != ((run - 1) * self.num) // self.den


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
    feedback: Cadence  # feedback messages (action_monitor_rate)
    state: Cadence | None  # controller_state messages (state_publish_rate; None: never)
    defaults: Tolerances
    cmd_timeout: float  # 0: off
    pid: Pids | None  # for a lone velocity or effort command
    velocity_error: bool  # which errors ros2_controllers computes (the rest stay 0)
    acceleration_error: bool
    limits: JointLimits  # joint_limits.<joint>.*: positions outside are refused


def read_settings(component: Any) -> Settings:
    """The settings of ``component`` (an rtcf.Component), or ConfigurationError."""
    p = ControllerParameters(component)
    joints = p.names("joints", [], non_empty=True)
    command_joints = p.names("command_joints", [])
    if command_joints and command_joints != joints:
        raise p.error("command_joints", command_joints,
                       "[] or the joints themselves (a subset is not supported by rtcf)")
    command_interfaces = _interfaces(p, "command_interfaces", COMMANDS)
    state_interfaces = _interfaces(p, "state_interfaces", _STATES)
    problem = _combination(command_interfaces, state_interfaces)
    if problem:
        raise p.error("command_interfaces", command_interfaces,
                       f"interfaces that go together: {problem}")
    for unsupported in ("allow_integration_in_goal_trajectories",
                        "constraints.decelerate_on_cancel"):
        if p.flag(unsupported, False):
            raise p.error(unsupported, True, "false (rtcf does not support it yet)")
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
        feedback=Cadence.of(monitor_rate, frequency),
        state=Cadence.of(state_rate, frequency) if state_rate > 0 else None,
        defaults=defaults,
        cmd_timeout=cmd_timeout if cmd_timeout > defaults.goal_time else 0.0,
        pid=Pids(p, joints) if use_pid else None,
        velocity_error="velocity" in states and bool({"velocity", "effort"} & commands),
        acceleration_error="acceleration" in states and "acceleration" in commands,
        limits=read_limits(p, joints),
    )
