"""A differential-drive base in the loop: a MuJoCo model where the motor drivers of a
mobile robot would be (docs/examples.md, "A differential-drive base").

Like MujocoArm, it is the hardware interface: ports named as ros2_control's
interfaces, one float64 array with a value per wheel: ``position`` and ``velocity``
(state), ``velocity_command`` (command). diff_drive_controller
(rtcf_controllers.DiffDriveController) drives it, as it drives a real base's driver
with the same ports.
"""

from __future__ import annotations

import math

import numpy as np

import rtcf

from . import _mujoco

MODEL = "diffbot.xml"  # shipped in rtcf_examples/models


class MujocoDiffbot(rtcf.Component):
    """The motor drivers of a simulated two-wheeled base: steps a MuJoCo model once per
    iteration, first in the loop (``is_first``).

    Reads ``velocity_command`` (each wheel's speed, rad/s; none yet: zero), which the
    model's velocity servos track, and writes what it measured after the step:
    ``position`` [rad] and ``velocity`` [rad/s] of the wheels, and ``~base_pose``
    (its own: ``/diffbot/base_pose`` for a component named diffbot), the ground truth
    that a real robot does not have: ``[x, y, yaw]`` [m, m, rad] of the base's body
    in the world (for tests and plots, beside the odometry).

    ``~joints`` orders the arrays (default: the model's actuated joints in its order,
    left_wheel_joint then right_wheel_joint for the shipped model, as
    diff_drive_controller's ``left_wheel_names`` then ``right_wheel_names``);
    ``~base_body`` names the body whose pose is the ground truth (default
    ``base_link``). ``~model`` is an MJCF file (default: the shipped diffbot), whose
    timestep must divide the component's period. Needs the ``mujoco`` package
    (``pip install 'rtcf[mujoco]'``).
    """

    def configure(self) -> None:
        sim = _mujoco.load_simulation(self, MODEL)
        mujoco, model, path = sim.mujoco, sim.model, sim.path
        self.mujoco, self.model, self.data, self.steps = mujoco, model, sim.data, sim.steps
        actuated = [model.joint(int(model.actuator_trnid[i, 0])).name for i in range(model.nu)]
        joints = [str(j) for j in self.params.get("~joints", actuated)]
        if sorted(joints) != sorted(actuated):
            raise rtcf.ConfigurationError(
                f"~joints is {joints}; give the joints that the model {path} actuates, "
                f"each once: {actuated}"
            )
        # the actuator, position and velocity of each joint, in ~joints' order
        self.joints = joints
        self.actuators = np.array([actuated.index(j) for j in joints])
        ids = [model.joint(j).id for j in joints]
        self.qpos = np.array([model.jnt_qposadr[i] for i in ids])
        self.qvel = np.array([model.jnt_dofadr[i] for i in ids])
        body = str(self.params.get("~base_body", "base_link"))
        try:
            self.base = model.body(body).id
        except KeyError:
            raise rtcf.ConfigurationError(
                f"~base_body {body!r}: the model {path} has no such body"
            ) from None
        mujoco.mj_forward(model, self.data)
        # the wheels' speeds, checked before each step: never a non-finite one, and
        # within the model's control range where it has one (launch files may narrow
        # it: joint_limits.<wheel>.max_velocity)
        self.velocity_command = self.add_command_input(
            "velocity_command", "velocity", joints,
            _mujoco.actuator_limits(model, self.actuators, "velocity"))
        self.position = self.add_output("position", np.ndarray)
        self.velocity = self.add_output("velocity", np.ndarray)
        self.base_pose = self.add_output("~base_pose", np.ndarray)
        self.log.info(
            "%s: wheels %s, %d step(s) of %g ms per iteration",
            path, ", ".join(joints), self.steps, float(model.opt.timestep) * 1e3,
        )

    def update(self) -> None:
        data = self.data
        command = self.velocity_command.read()
        if command is not None:
            data.ctrl[self.actuators] = command
        self.mujoco.mj_step(self.model, data, self.steps)
        self.position.write(data.qpos[self.qpos])  # fancy indexing: a new array each
        self.velocity.write(data.qvel[self.qvel])
        x, y = data.xpos[self.base, :2]
        w, qx, qy, qz = data.xquat[self.base]
        yaw = math.atan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        self.base_pose.write(np.array((x, y, yaw)))

    def safe_stop(self) -> bool:
        """Brake: every wheel's servo to zero speed, as a driver does when its
        controller stops commanding it."""
        self.data.ctrl[:] = 0.0
        self.log.warning("safe stop: wheels braked to zero speed")
        return True


class TwistSequence(rtcf.Component):
    """Drives a base without ROS: ``geometry_msgs/TwistStamped`` on ``cmd_vel``, stamped
    with the iteration's time, through ``~segments`` in turn, then nothing (the
    controller's ``cmd_vel_timeout`` brakes the base: what a teleop that stops
    publishing does). ``~segments`` lists ``linear.x`` [m/s], ``angular.z`` [rad/s] and
    seconds for each segment one after the other (ROS parameters take flat lists).
    Writes at its own rate (``rate``; 50 Hz in diffbot.launch, as teleop publishes).
    Needs geometry_msgs (ROS 2: pip install 'rtcf[ros2]').
    """

    def configure(self) -> None:
        try:
            from geometry_msgs.msg import TwistStamped
        except ImportError:
            raise rtcf.ConfigurationError(
                "TwistSequence needs geometry_msgs: pip install 'rtcf[ros2]'"
            ) from None
        flat = [float(x) for x in self.params.get("~segments", [])]
        if not flat or len(flat) % 3 or any(s <= 0.0 for s in flat[2::3]):
            raise rtcf.ConfigurationError(
                f"~segments is {flat}: give linear [m/s], angular [rad/s] and seconds > 0 "
                "for each segment, one after the other"
            )
        self.segments = [tuple(flat[k : k + 3]) for k in range(0, len(flat), 3)]
        self.ends = np.cumsum([s for _, _, s in self.segments])
        self.message = TwistStamped
        self.cmd_vel = self.add_output("cmd_vel", TwistStamped)

    def update(self) -> None:
        k = int(np.searchsorted(self.ends, self.time, side="right"))
        if k >= len(self.segments):
            return  # done: no more commands
        message = self.message()  # a new one per write: a reader may still hold the last
        self.stamp_to(message.header.stamp)
        message.twist.linear.x, message.twist.angular.z = self.segments[k][:2]
        self.cmd_vel.write(message)
