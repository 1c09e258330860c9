"""The policy component: an ONNX model between ports, configured by a deploy YAML."""

from __future__ import annotations

import math

import numpy as np

import rtcf

from ._config import PolicyConfig, load_config
from ._observation import Observation
from ._session import OnnxPolicy
from ._timing import ERROR, WARN, Timing, delay_mismatch, period_mismatch


class Policy(rtcf.Component):
    """A learned policy: each time it runs, the observation from its input ports (as
    ``~config`` says), the model once (onnxruntime, made in ``configure``), and the
    action to its output port: ``clip(raw, -clip, clip) * scale + offset`` (offset: the
    default joint positions), a float64 array.

    Give it a rate (``every``) and, for a model heavier than a period, a lane of its own
    on logical execution time: it then reads its inputs as the iteration before its
    release left them, and its action appears exactly ``every`` iterations later
    (docs/policies.md).

    Parameters: ``~config`` (the YAML file), ``~model`` (replaces the configuration's
    model), ``~publish_observation`` (also write the observation it fed the model, a
    float32 array, to ``observation``), ``~silent_after_s`` (write nothing from that
    time on: a policy gone quiet, to try what reads it), ``~on_delay_mismatch``
    (``error``, the default, or ``warn``: below).

    ``configure`` checks the configuration's ``control_dt`` against the period it runs
    at (``every`` over the loop's frequency: a mismatch is an error) and its
    ``trained_delay`` against the delay it runs with (on LET ``every + 1`` loop
    periods, inline none): an error, or with ``~on_delay_mismatch:=warn`` a warning, to
    rehearse a policy run without the delay it was trained with.

    Its ``update`` imports nothing and starts no thread; assembling the observation and
    the inference allocate nothing (preallocated arrays, bound once); each value it
    writes is a new array (a port passes values by reference: a reader may keep it).
    """

    def configure(self) -> None:
        path = str(self.params.get("~config", ""))
        if not path:
            raise rtcf.ConfigurationError("give ~config, the policy's YAML configuration")
        config = load_config(path, str(self.params.get("~model", "") or ""))
        self.config = config
        self.timing = self._check_timing(config)
        self.model = OnnxPolicy(config, type(self).__name__)
        ports = {}
        for term in config.terms:
            if term.port and term.port not in ports:
                ports[term.port] = self.add_input(term.port, np.ndarray)
        spec = config.action
        self.action_port = self.add_output(spec.port, np.ndarray)
        self.raw = np.zeros(spec.size)  # the last raw action (clipped): last_action terms
        self.observation = Observation(config, self.model.observation_flat, ports, self.raw)
        self.scale, self.offset = spec.scale, spec.offset
        self.low, self.high = -spec.clip, spec.clip
        self.publish = bool(self.params.get("~publish_observation", False))
        self.observation_port = (
            self.add_output("observation", np.ndarray) if self.publish else None)
        silent = float(self.params.get("~silent_after_s", math.inf))
        loop_hz = self.frequency * self.every
        self.silent_at = math.ceil(silent * loop_hz - 1e-9) if silent < math.inf else (
            1 << 62)  # the first iteration that writes nothing
        self.log.nonrt.info(
            "%s: onnxruntime %s, observation %s, action %d -> %s; %s",
            config.model, self.model.version, config.describe_terms(), spec.size, spec.port,
            self.timing.summary(),
        )

    def _check_timing(self, config: PolicyConfig) -> Timing:
        """How it runs, against the configuration's control_dt and trained_delay."""
        on_mismatch = str(self.params.get("~on_delay_mismatch", ERROR))
        if on_mismatch not in (ERROR, WARN):
            raise rtcf.ConfigurationError(
                f"~on_delay_mismatch is {on_mismatch!r}: give error or warn")
        timing = Timing(self.frequency * self.every, self.every, self.on_let, self.lane_name)
        problem = period_mismatch(config, timing)
        if problem:
            raise rtcf.ConfigurationError(problem)
        problem = delay_mismatch(config, timing)
        if problem and on_mismatch == ERROR:
            raise rtcf.ConfigurationError(problem)
        if problem:
            self.log.nonrt.warning("%s", problem)
        return timing

    def start(self) -> None:
        self.observation.reset()
        self.raw[:] = 0.0

    def update(self) -> None:
        if self.iteration >= self.silent_at:
            return
        if not self.observation.assemble():
            return  # a port without a default has no value yet
        model = self.model
        model.run()
        raw = self.raw
        np.minimum(model.action_flat, self.high, out=raw)
        np.maximum(raw, self.low, out=raw)
        # a new array per value written (ports pass values by reference, and a reader, a
        # trace or a recording may keep it): the one allocation of a release, 1 array
        target = np.multiply(raw, self.scale)
        np.add(target, self.offset, out=target)
        self.action_port.write(target)
        if self.observation_port is not None:
            self.observation_port.write(model.observation_flat.copy())
