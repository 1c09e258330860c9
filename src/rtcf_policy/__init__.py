"""Learned policies in the loop: an ONNX model between ports (``Policy``), configured by
a deploy YAML with legged_gym's, unitree_rl_gym's and IsaacLab's field names, and the PD
stage its position targets go through (``JointPd``). Needs onnxruntime:
``pip install 'rtcf[policy]'`` (docs/policies.md).

Load them from a launch file with ``args="rtcf_policy Policy"`` and
``args="rtcf_policy JointPd"``.
"""

from ._config import ActionSpec as ActionSpec
from ._config import PolicyConfig as PolicyConfig
from ._config import Term as Term
from ._config import load_config as load_config
from ._config import parse_config as parse_config
from ._pd import JointPd as JointPd
from ._policy import Policy as Policy

__all__ = ["ActionSpec", "JointPd", "Policy", "PolicyConfig", "Term", "load_config",
           "parse_config"]
