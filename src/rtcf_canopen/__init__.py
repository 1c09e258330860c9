"""CiA 402 drives over CANopen as an rtcf hardware component (``rtcf_canopen/Cia402System``).

A package of its own beside rtcf: it needs python-can and canopen (``pip install
'rtcf[canopen]'``), which the core does not. :mod:`rtcf_canopen.sim_drive` is a simulated
drive to run it against (docs/canopen.md).
"""

from ._system import Cia402System as Cia402System

__all__ = ["Cia402System"]
