"""An ONNX model in the loop: one onnxruntime session made for a real-time thread.

Made in ``configure`` (in the worker): one intra-op and one inter-op thread and
sequential execution (so onnxruntime starts no thread of its own; spinning off), the
observation and the action preallocated as numpy arrays and bound once (IOBinding), so
that :meth:`OnnxPolicy.run` is one call into onnxruntime that allocates nothing in
Python. A model whose input or output does not have the configuration's shape is a
ConfigurationError naming both shapes, the model file and the terms.
"""

from __future__ import annotations

from typing import Any

import numpy as np

import rtcf

from ._config import PolicyConfig


def import_onnxruntime(who: str) -> Any:
    try:
        import onnxruntime
    except ImportError:
        raise rtcf.ConfigurationError(
            f"{who} needs the onnxruntime package: pip install 'rtcf[policy]'"
        ) from None
    return onnxruntime


def session_options(ort: Any) -> Any:
    """One thread for everything, sequential, no spinning: a loop's guest."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    options.add_session_config_entry("session.inter_op.allow_spinning", "0")
    options.log_severity_level = 3  # errors only: its warnings are no business of the loop
    return options


class OnnxPolicy:
    """``run()``: the model on ``observation`` (float32, shape (1, num_obs) or
    (num_obs,) as the model has it) into ``action`` (float32, likewise)."""

    def __init__(self, config: PolicyConfig, who: str) -> None:
        ort = import_onnxruntime(who)
        model = config.model
        try:
            self.session = ort.InferenceSession(
                model, session_options(ort), providers=["CPUExecutionProvider"]
            )
        except Exception as exc:  # onnxruntime's own exception types (Fail, NoSuchFile, ...)
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise rtcf.ConfigurationError(
                f"model {model} could not be loaded: {first}"
            ) from None
        inputs, outputs = self.session.get_inputs(), self.session.get_outputs()
        if len(inputs) != 1 or len(outputs) != 1:
            raise rtcf.ConfigurationError(
                f"model {model} has {len(inputs)} input(s) and {len(outputs)} "
                "output(s); a policy takes one observation and gives one action"
            )
        self.input, self.output = inputs[0], outputs[0]
        n, m = config.num_obs, config.action.size
        self.observation = _buffer(self.input, n, model, who, "input", "observation",
                                   config.describe_terms())
        self.action = _buffer(self.output, m, model, who, "output", "action",
                              f"action ({config.action.port}: {m} numbers)")
        # flat views, made once: update fills and reads them without a new object
        self.observation_flat = self.observation.reshape(-1)
        self.action_flat = self.action.reshape(-1)
        self.binding = self.session.io_binding()
        self.binding.bind_cpu_input(self.input.name, self.observation)
        self.binding.bind_output(
            self.output.name, "cpu", 0, np.float32, list(self.action.shape),
            self.action.ctypes.data,
        )
        self.run_options = ort.RunOptions()
        self.version = ort.__version__
        self.run()  # the first run allocates onnxruntime's own buffers: not in the loop

    def run(self) -> None:
        """The model once: observation in, action out (the bound arrays)."""
        self.session.run_with_iobinding(self.binding, self.run_options)


def _buffer(arg: Any, size: int, model: str, who: str, kind: str, what: str,
            terms: str) -> np.ndarray:
    """A float32 array of the model's shape for ``arg`` holding ``size`` numbers (a batch
    dimension of 1, or a symbolic one, taken as 1); else the error naming both."""
    if arg.type != "tensor(float)":
        raise rtcf.ConfigurationError(
            f"model {model}: its {kind} {arg.name!r} is {arg.type}; a policy's "
            f"{what} is float32 (tensor(float))"
        )
    shape = [d if isinstance(d, int) and d > 0 else 1 for d in arg.shape]
    if (len(shape) not in (1, 2) or shape[-1] != size or (len(shape) == 2 and shape[0] != 1)):
        shown = "[" + ", ".join(str(d) for d in arg.shape) + "]"
        raise rtcf.ConfigurationError(
            f"model {model}: its {kind} {arg.name!r} has shape {shown}, the "
            f"configuration's {what} [1, {size}]: {terms}; make the configuration's terms "
            "match what the model was trained with"
        )
    return np.zeros(shape, dtype=np.float32)
