"""Example components of rtcf: Python counterparts of the original RTCF examples.

Load them from a launch file with ``args="rtcf_examples ClassName"``.
"""

from ._components import (
    BareMinimum,
    FirstOrderPlant,
    Identity,
    Logging,
    Mimo,
    PaperExample,
    ParameterHandling,
    Sine,
)

__all__ = [
    "BareMinimum",
    "FirstOrderPlant",
    "Identity",
    "Logging",
    "Mimo",
    "PaperExample",
    "ParameterHandling",
    "Sine",
]
