"""The PD stage a policy's position targets go through, at the loop's rate."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import rtcf

from ._config import PolicyConfig, load_config

HOLD, BRAKE = "hold", "brake"


class JointPd(rtcf.Component):
    """``effort_command = kp (target - q) - kd qd``, clipped to ``~effort_limit``.

    **Which joints, in which order.** By name: ``~joints`` lists the driver's joints in
    the order of its ``position`` and ``velocity`` arrays, ``~command_joints`` (default
    ``~joints``) in the order of its ``effort_command``; the policy's ``joints`` (its
    configuration) say which element of ``target`` is which. ``effort_command`` is then
    in the driver's order, one element per command joint: exactly the policy's joints
    (an unknown or missing name is a configuration error naming it). Without names,
    ``~index`` picks the policy's joints out of ``position`` and ``velocity`` (all by
    default) and ``effort_command`` is in the policy's order. ``~kp``, ``~kd`` and
    ``~default`` are in the policy's order either way.

    ``kp``/``kd`` (and the target before the first action: the default joint positions)
    come from the policy's ``~config`` (``kps``, ``kds``, ``action.offset`` or
    ``default_angles``), or the parameters ``~kp``, ``~kd``, ``~default`` (which win).

    **When the policy goes quiet**: give ``target`` a deadline (the launch file's
    ``deadline/target``, in seconds). Past it (``EXPIRED``) the stage does what
    ``~safe_behaviour`` says until a target comes again, and logs each change:
    ``hold`` (the default) holds the joints where they were at that moment with the
    same gains; ``brake`` sets kp to 0, leaving the damping: the joints come to rest
    wherever that is.
    """

    def configure(self) -> None:
        path = str(self.params.get("~config", "") or "")
        config = load_config(path) if path else None
        self.position = self.add_input("position", np.ndarray)
        self.velocity = self.add_input("velocity", np.ndarray)
        self.target = self.add_input("target", np.ndarray)
        self.effort_command = self.add_output("effort_command", np.ndarray)
        index = self.params.get("~index", None)
        self.index = None if index is None else np.array(index, dtype=np.intp).reshape(-1)
        # by name: the driver's joints (~joints, ~command_joints) against the policy's
        self.order: np.ndarray | None = None  # command slot -> the target's element
        self.command_joints: list[str] = []
        if self.params.get("~joints", None) is not None:
            if index is not None:
                raise rtcf.ConfigurationError(
                    "give ~joints (the driver's joint names) or ~index, not both")
            self.index, self.order, self.command_joints = joint_map(
                config, self.params.get("~joints"), self.params.get("~command_joints", None))
            if (self.order == np.arange(len(self.order))).all():
                self.order = None  # the same order: the target as it comes
        elif self.params.get("~command_joints", None) is not None:
            raise rtcf.ConfigurationError(
                "~command_joints needs ~joints: the driver's joint names, in the order of "
                "its position and velocity")
        n = (len(self.index) if self.index is not None
             else config.action.size if config is not None else 0)
        kp = self.params.get("~kp", None)
        kd = self.params.get("~kd", None)
        default = self.params.get("~default", None)
        if config is not None:
            kp = config.kps if kp is None else kp
            kd = config.kds if kd is None else kd
            default = config.action.offset if default is None else default
        if kp is None or kd is None or n == 0:
            raise rtcf.ConfigurationError(
                "give ~config (a policy configuration with kps and "
                "kds) or ~kp, ~kd and ~index")
        # in the policy's order, as given; then in the driver's (the command's) order
        self.kp = self._driver_order(_vector(kp, n, "~kp", self.full_name))
        self.kd = self._driver_order(_vector(kd, n, "~kd", self.full_name))
        self.default = self._driver_order(
            _vector(0.0 if default is None else default, n, "~default", self.full_name))
        self.ordered = np.zeros(n)  # the target in the driver's order
        self.limit = float(self.params.get("~effort_limit", math.inf))
        self.low = -self.limit
        behaviour = str(self.params.get("~safe_behaviour", HOLD))
        if behaviour not in (HOLD, BRAKE):
            raise rtcf.ConfigurationError(
                f"~safe_behaviour is {behaviour!r}: give hold or brake")
        self.brake = behaviour == BRAKE
        self.behaviour = behaviour
        self.no_gain = np.zeros(n)
        self.q = np.zeros(n)
        self.qd = np.zeros(n)
        self.held = np.zeros(n)
        self.work = np.zeros(n)
        self.safe = False
        self.changes: list[tuple[int, str]] = []  # (iteration, "safe" or "follow"), in turn
        self.changes_left = 64  # kept (preallocated room: no list growth past it)

    def start(self) -> None:
        self.safe = False

    def update(self) -> None:
        position = self.position.read()
        velocity = self.velocity.read()
        if position is None or velocity is None:
            return  # nothing measured yet: command nothing
        q, qd = self.q, self.qd
        if self.index is None:
            np.copyto(q, position)
            np.copyto(qd, velocity)
        else:
            position.take(self.index, out=q)
            velocity.take(self.index, out=qd)
        kp = self.kp
        if self.target.status is rtcf.FlowStatus.EXPIRED:
            if not self.safe:
                self.safe = True
                self._note("safe")
                np.copyto(self.held, q)
                self.log.warning(
                    "target past its deadline at iteration %d: %s", self.iteration,
                    "braking (kp 0)" if self.brake else f"holding at {q.tolist()}")
            target = self.held
            if self.brake:
                kp = self.no_gain
        else:
            if self.safe:
                self.safe = False
                self._note("follow")
                self.log.info("target again at iteration %d: following it", self.iteration)
            value = self.target.read()
            if value is None:
                target = self.default
            elif self.order is None:
                target = value
            else:  # the policy's order -> the driver's: one take into a preallocated row
                target = value.take(self.order, out=self.ordered)
        work = self.work
        effort = np.subtract(target, q)  # a new array per value written (a reader may keep it)
        np.multiply(effort, kp, out=effort)
        np.multiply(qd, self.kd, out=work)
        np.subtract(effort, work, out=effort)
        if self.limit != math.inf:
            np.minimum(effort, self.limit, out=effort)
            np.maximum(effort, self.low, out=effort)
        self.effort_command.write(effort)

    def _driver_order(self, values: np.ndarray) -> np.ndarray:
        """Per-joint values in the policy's order, in the driver's command order."""
        return values if self.order is None else values[self.order]

    def _note(self, what: str) -> None:
        """What tests and tools read: when it went to its safe behaviour and back."""
        if self.changes_left:
            self.changes_left -= 1
            self.changes.append((self.iteration, what))


def _vector(value: object, n: int, what: str, name: str) -> np.ndarray:
    array = np.array(value, dtype=np.float64).reshape(-1)
    if array.size == 1:
        array = np.full(n, array[0])
    if array.size != n or not np.isfinite(array).all():
        raise rtcf.ConfigurationError(
            f"{what} is {value!r}: give a number or a list of {n}")
    return array


def joint_map(config: PolicyConfig | None, joints: Any,
              command_joints: Any) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The PD stage's joints by name: for each element of the driver's ``effort_command``
    (``command_joints``, default ``joints``), the element of ``position``/``velocity``
    (the driver's ``joints``) and of the policy's target (the configuration's ``joints``)
    that is that joint. Every command joint must be a policy joint and the reverse
    (each the other's permutation); an unknown or missing name is an error naming it."""

    def fail(what: str) -> rtcf.ConfigurationError:
        return rtcf.ConfigurationError(what)

    if config is None or not config.joints:
        where = f"policy configuration {config.path}" if config is not None else "~config"
        raise fail(f"~joints maps the driver's joints to the policy's by name, but {where} "
                   "names none: give joints: [...] in the policy's order")
    policy = config.joints
    if len(policy) != config.action.size:
        raise fail(f"policy configuration {config.path}: joints has {len(policy)} names, "
                   f"the action {config.action.size} numbers")
    state = _names(joints, "~joints")
    command = state if command_joints is None else _names(command_joints, "~command_joints")
    for names, what in ((policy, f"the policy configuration {config.path}'s joints"),
                        (state, "~joints"), (command, "~command_joints")):
        twice = next((j for j in names if names.count(j) > 1), None)
        if twice is not None:
            raise fail(f"joint {twice!r} is in {what} twice")
    commands = "~command_joints" if command_joints is not None else "~joints"
    for joint in policy:
        if joint not in state:
            raise fail(f"policy joint {joint!r} ({config.path}) is not among the driver's "
                       f"~joints {state}: give the driver's names for all of the policy's "
                       f"joints {policy}")
        if joint not in command:
            raise fail(f"policy joint {joint!r} ({config.path}) is not among the driver's "
                       f"{commands} {command}: the PD stage commands every joint the policy "
                       "drives")
    for joint in command:
        if joint not in policy:
            raise fail(f"driver joint {joint!r} ({commands}) is not among the policy's "
                       f"joints {policy} ({config.path}): the PD stage has no target for it; "
                       f"give {'~command_joints with ' if command_joints is None else ''}"
                       "only the joints the policy drives, in the driver's order")
    index = np.array([state.index(j) for j in command], dtype=np.intp)
    order = np.array([policy.index(j) for j in command], dtype=np.intp)
    return index, order, command


def _names(value: Any, what: str) -> list[str]:
    if isinstance(value, str) or not isinstance(value, (list, tuple)) or not value:
        raise rtcf.ConfigurationError(
            f"{what} is {value!r}: give a list of joint names")
    return [str(j) for j in value]
