"""Example components of rtcf: Python counterparts of the original RTCF examples.

Load them from a launch file with ``args="rtcf_examples ClassName"``.
"""

from ._components import (
    BareMinimum,
    Busy,
    DcMotor,
    FirstOrderPlant,
    Identity,
    Logging,
    Mimo,
    PaperExample,
    ParameterHandling,
    Pid,
    Sine,
    StepSupervisor,
)

__all__ = [
    "BareMinimum",
    "Busy",
    "DcMotor",
    "FirstOrderPlant",
    "Identity",
    "Logging",
    "Mimo",
    "PaperExample",
    "ParameterHandling",
    "Pid",
    "Sine",
    "StepSupervisor",
]
