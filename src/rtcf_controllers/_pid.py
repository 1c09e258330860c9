"""One degree of freedom's PID, as control_toolbox's ``Pid`` computes it (Jazzy).

pid_controller keeps one per dof, with the gains of its ``gains.<dof>.*`` parameters.
The arithmetic follows control_toolbox's ``Pid::compute_command`` of the Jazzy branch
step by step, so a command matches ros2_control's to the last bit where the same
operations run in the same order: the derivative of the error by a backward difference
from 0 after a reset, the anti-windup strategies (``legacy`` with ``i_clamp_*`` and
``antiwindup``, ``none``, ``conditional_integration``, ``back_calculation``), no
integration inside ``error_deadband``, the output clamped to ``u_clamp_*``.
Plain floats, no numpy: a few dofs per controller, each update a handful of
operations.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from ._params import ControllerParameters

STRATEGIES = ("legacy", "none", "conditional_integration", "back_calculation")
_EPSILON = sys.float_info.epsilon  # control_toolbox's is_zero tolerance


@dataclass
class Gains:
    """``gains.<dof>.*`` of pid_controller's YAML file, with its defaults."""

    p: float = 0.0
    i: float = 0.0
    d: float = 0.0
    u_clamp_max: float = math.inf
    u_clamp_min: float = -math.inf
    i_clamp_max: float = math.inf
    i_clamp_min: float = -math.inf
    antiwindup: bool = False
    antiwindup_strategy: str = "legacy"
    tracking_time_constant: float = 0.0
    error_deadband: float = 1e-16
    feedforward_gain: float = 0.0
    angle_wraparound: bool = False
    save_i_term: bool = True

    @classmethod
    def read(cls, params: ControllerParameters, dof: str) -> Gains:
        """The gains of ``dof``, checked as control_toolbox checks them."""
        prefix = f"gains.{dof}."
        d = cls()
        gains = cls(
            p=params.number(prefix + "p", d.p),
            i=params.number(prefix + "i", d.i),
            d=params.number(prefix + "d", d.d),
            u_clamp_max=params.number(prefix + "u_clamp_max", d.u_clamp_max),
            u_clamp_min=params.number(prefix + "u_clamp_min", d.u_clamp_min),
            i_clamp_max=params.number(prefix + "i_clamp_max", d.i_clamp_max),
            i_clamp_min=params.number(prefix + "i_clamp_min", d.i_clamp_min),
            antiwindup=params.flag(prefix + "antiwindup", d.antiwindup),
            antiwindup_strategy=params.text(
                prefix + "antiwindup_strategy", d.antiwindup_strategy, choices=STRATEGIES
            ),
            tracking_time_constant=params.number(
                prefix + "tracking_time_constant", d.tracking_time_constant
            ),
            error_deadband=params.number(prefix + "error_deadband", d.error_deadband),
            feedforward_gain=params.number(prefix + "feedforward_gain", d.feedforward_gain),
            angle_wraparound=params.flag(prefix + "angle_wraparound", d.angle_wraparound),
            save_i_term=params.flag(prefix + "save_i_term", d.save_i_term),
        )
        if not params.flag(prefix + "saturation", gains.saturated):
            gains.u_clamp_max, gains.u_clamp_min = math.inf, -math.inf
        problem = gains.problem()
        if problem:
            raise params.error(prefix + problem[0], problem[1], problem[2])
        if gains.antiwindup_strategy == "back_calculation" and gains.tracking_time_constant == 0:
            # control_toolbox's default time constant for back calculation
            if gains.i != 0 and gains.d != 0:
                gains.tracking_time_constant = math.sqrt(gains.d / gains.i)
            elif gains.i != 0:
                gains.tracking_time_constant = gains.p / gains.i
        return gains

    @property
    def saturated(self) -> bool:
        return math.isfinite(self.u_clamp_max) or math.isfinite(self.u_clamp_min)

    def problem(self) -> tuple[str, float, str] | None:
        """(parameter, value, what to give) for gains control_toolbox refuses."""
        if self.i_clamp_min > 0:
            return ("i_clamp_min", self.i_clamp_min, "a number <= 0")
        if self.i_clamp_max < 0:
            return ("i_clamp_max", self.i_clamp_max, "a number >= 0")
        if self.u_clamp_min > self.u_clamp_max:
            return ("u_clamp_min", self.u_clamp_min, f"a number <= u_clamp_max {self.u_clamp_max}")
        if self.antiwindup_strategy == "back_calculation" and not (
            self.tracking_time_constant >= 0 and math.isfinite(self.tracking_time_constant)
        ):
            return ("tracking_time_constant", self.tracking_time_constant, "a number >= 0")
        return None


class Pid:
    """One dof's state: the integral term, the last error, the last command."""

    __slots__ = ("_strategy", "command", "gains", "i_term", "p_error_last")

    def __init__(self, gains: Gains) -> None:
        self.gains = gains
        self._strategy = STRATEGIES.index(gains.antiwindup_strategy)
        self.i_term = 0.0
        self.p_error_last = 0.0
        self.command = 0.0

    def reset(self) -> None:
        """At activation: the error history and the command cleared; the integral
        term too unless ``save_i_term``."""
        self.p_error_last = 0.0
        self.command = 0.0
        if not self.gains.save_i_term:
            self.i_term = 0.0

    def compute(self, error: float, dt: float) -> float:
        """The command from the error alone: its derivative by a backward difference."""
        if abs(dt) <= _EPSILON:
            return self.command
        if not math.isfinite(error):
            self.command = math.nan
            return math.nan
        error_dot = (error - self.p_error_last) / dt
        self.p_error_last = error
        return self.compute_with_rate(error, error_dot, dt)

    def compute_with_rate(self, error: float, error_dot: float, dt: float) -> float:
        """The command from the error and its derivative (control_toolbox's order)."""
        if abs(dt) <= _EPSILON:
            return self.command
        if not (math.isfinite(error) and math.isfinite(error_dot)):
            self.command = math.nan
            return math.nan
        g = self.gains
        strategy = self._strategy
        p_term = g.p * error
        d_term = g.d * error_dot
        integrate = abs(error) > g.error_deadband
        i_term = self.i_term
        if strategy == 0:  # legacy
            if integrate:
                i_term += g.i * dt * error
                if g.antiwindup:
                    i_term = min(max(i_term, g.i_clamp_min), g.i_clamp_max)
            clamped = i_term if g.antiwindup else min(max(i_term, g.i_clamp_min), g.i_clamp_max)
            unsaturated = p_term + clamped + d_term
        else:
            unsaturated = p_term + i_term + d_term
        command = unsaturated
        if g.saturated:
            command = min(max(unsaturated, g.u_clamp_min), g.u_clamp_max)
        if integrate:
            if strategy == 3 and g.i != 0:  # back_calculation
                i_term += dt * (
                    g.i * error + 1 / g.tracking_time_constant * (command - unsaturated)
                )
            elif strategy == 2:  # conditional_integration
                if not (abs(unsaturated - command) > _EPSILON and error * unsaturated > 0):
                    i_term += dt * g.i * error
            elif strategy == 1:  # none
                i_term += dt * g.i * error
        self.i_term = min(max(i_term, g.i_clamp_min), g.i_clamp_max)
        self.command = command
        return command


def shortest_angular_distance(start: float, end: float) -> float:
    """``end - start`` normalised to (-pi, pi], as the angles package computes it."""
    result = math.fmod(end - start + math.pi, 2.0 * math.pi)
    return result + math.pi if result <= 0.0 else result - math.pi

