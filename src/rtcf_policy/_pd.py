"""The PD stage a policy's position targets go through, at the loop's rate."""

from __future__ import annotations

import math

import numpy as np

import rtcf

from ._config import load_config

HOLD, BRAKE = "hold", "brake"


class JointPd(rtcf.Component):
    """``effort_command = kp (target - q) - kd qd``, clipped to ``~effort_limit``, for
    the joints ``~index`` picks out of ``position`` and ``velocity`` (all by default).

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
        self.kp = _vector(kp, n, "~kp", self.full_name)
        self.kd = _vector(kd, n, "~kd", self.full_name)
        self.default = _vector(0.0 if default is None else default, n, "~default", self.full_name)
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
            target = self.default if value is None else value
        work = self.work
        effort = np.subtract(target, q)  # a new array per value written (a reader may keep it)
        np.multiply(effort, kp, out=effort)
        np.multiply(qd, self.kd, out=work)
        np.subtract(effort, work, out=effort)
        if self.limit != math.inf:
            np.minimum(effort, self.limit, out=effort)
            np.maximum(effort, self.low, out=effort)
        self.effort_command.write(effort)

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
