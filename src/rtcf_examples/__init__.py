"""Example components of rtcf: Python counterparts of the original RTCF examples.

Load them from a launch file with ``args="rtcf_examples ClassName"``.
"""

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

__all__ = [
    "BareMinimum",
    "Busy",
    "DcMotor",
    "FirstOrderPlant",
    "Gain",
    "Identity",
    "Logging",
    "Mimo",
    "PaperExample",
    "ParameterHandling",
    "Pid",
    "Ramp",
    "Sine",
    "StepSupervisor",
]
