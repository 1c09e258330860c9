"""A cart-pole in the loop: the hardware interface of the learned-policy example
(docs/policies.md, docs/examples.md "A learned policy on a cart-pole").

Like MujocoArm: ports named as ros2_control's interfaces, float64 arrays, one value per
joint, the cart's slider first: ``position`` [m, rad] and ``velocity`` [m/s, rad/s] of
both joints (state), ``effort_command`` [N] of the slider, the one actuated (command).
A driver of a real cart-pole with the same ports takes its place (the launch file's
``hardware`` argument) and nothing else changes.
"""

from __future__ import annotations

import math

import numpy as np

import rtcf

from . import _mujoco

MODEL = "cartpole.xml"  # shipped in rtcf_examples/models


class MujocoCartPole(rtcf.Component):
    """The hardware interface of a simulated cart-pole: steps a MuJoCo model once per
    iteration, first in the loop (``is_first``).

    Reads ``effort_command`` (the cart's force, N; none yet: zero), checked against the
    model's control range, and writes what it measured after the step: ``position``
    ``[cart, pole angle]`` and ``velocity`` (both joints).

    ``~initial_angle`` [rad] tilts the pole at the start. ``~push_at_s``,
    ``~push_force`` [N] and ``~push_duration_s`` push the pole's tip sideways (+x) for
    a moment: a disturbance to recover from. ``~model`` is an MJCF file (default: the
    shipped cart-pole) with a slider (actuated) and a hinge. Needs the ``mujoco``
    package (``pip install 'rtcf[mujoco]'``).
    """

    def configure(self) -> None:
        sim = _mujoco.load_simulation(self, MODEL)
        mujoco, model, path = sim.mujoco, sim.model, sim.path
        self.mujoco, self.model, self.data, self.steps = mujoco, model, sim.data, sim.steps
        if model.nq != 2 or model.nv != 2 or model.nu != 1:
            raise rtcf.ConfigurationError(
                f"~model {path}: MujocoCartPole drives a slider and a hinge with one motor "
                f"on the slider; this model has {model.nq} positions, {model.nv} "
                f"velocities and {model.nu} actuators"
            )
        slider = model.joint(int(model.actuator_trnid[0, 0])).name
        self.data.qpos[:] = (0.0, float(self.params.get("~initial_angle", 0.0)))
        mujoco.mj_forward(model, self.data)
        self.effort_command = self.add_command_input(
            "effort_command", "effort", [slider],
            _mujoco.actuator_limits(model, range(1), "effort"))
        self.position = self.add_output("position", np.ndarray)
        self.velocity = self.add_output("velocity", np.ndarray)
        hz = self.frequency * self.every
        push_at = float(self.params.get("~push_at_s", math.inf))
        duration = float(self.params.get("~push_duration_s", 0.05))
        self.push = (
            (math.inf, math.inf) if not push_at < math.inf
            else (round(push_at * hz), round((push_at + duration) * hz))
        )
        self.push_force = float(self.params.get("~push_force", 0.0))
        self.tip = model.body("pole").id
        self.log.nonrt.info(
            "%s: cart-pole, %d step(s) of %g ms per iteration%s", path, self.steps,
            float(model.opt.timestep) * 1e3,
            f"; a push of {self.push_force:g} N at {push_at:g} s" if push_at < math.inf else "",
        )

    def update(self) -> None:
        data = self.data
        command = self.effort_command.read()
        if command is not None:
            data.ctrl[0] = command[0]
        i = self.iteration
        force = self.push_force if self.push[0] <= i < self.push[1] else 0.0
        # the push acts at the pole's centre of mass, sideways (MuJoCo's applied force)
        data.xfrc_applied[self.tip, 0] = force
        self.mujoco.mj_step(self.model, data, self.steps)
        self.position.write(data.qpos.copy())
        self.velocity.write(data.qvel.copy())

    def safe_stop(self) -> bool:
        """Stop the cart where it is, as a drive does when its controller stops: the
        motor becomes a position servo about the cart's position of this moment (the
        pole, unactuated, falls)."""
        mujoco, model, data = self.mujoco, self.model, self.data
        kp = float(self.params.get("~hold_stiffness", 200.0))
        kv = float(self.params.get("~hold_damping", 40.0))
        model.actuator_gaintype[0] = mujoco.mjtGain.mjGAIN_FIXED
        model.actuator_biastype[0] = mujoco.mjtBias.mjBIAS_AFFINE
        model.actuator_gainprm[0, 0] = kp
        model.actuator_biasprm[0, :3] = (0.0, -kp, -kv)
        model.actuator_ctrllimited[0] = 0
        data.ctrl[0] = data.qpos[0]
        self.log.warning("safe stop: holding the cart at %.3f m", float(data.qpos[0]))
        return True
