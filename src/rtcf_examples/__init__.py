"""Example components of rtcf: Python counterparts of the original RTCF examples.

Load them from a launch file with ``args="rtcf_examples ClassName"``.
"""

from ._arm import (
    HoldPosition,
    JointImpedance,
    JointStateBroadcaster,
    MujocoArm,
    TrajectoryInterpolator,
)
from ._cartpole import MujocoCartPole
from ._components import (
    BareMinimum,
    Busy,
    DcMotor,
    FirstOrderPlant,
    Gain,
    Identity,
    Logging,
    Mimo,
    PaperExample,
    ParameterHandling,
    Pid,
    Ramp,
    Sine,
    StepSupervisor,
)
from ._diffbot import MujocoDiffbot, TwistSequence
from ._mujoco_system import MujocoSystem

__all__ = [
    "BareMinimum",
    "Busy",
    "DcMotor",
    "FirstOrderPlant",
    "Gain",
    "HoldPosition",
    "Identity",
    "JointImpedance",
    "JointStateBroadcaster",
    "Logging",
    "Mimo",
    "MujocoArm",
    "MujocoCartPole",
    "MujocoDiffbot",
    "MujocoSystem",
    "PaperExample",
    "ParameterHandling",
    "Pid",
    "Ramp",
    "Sine",
    "StepSupervisor",
    "TrajectoryInterpolator",
    "TwistSequence",
]
