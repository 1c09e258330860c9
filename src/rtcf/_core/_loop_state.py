"""The state of the running loop that components may read: iteration, time, rate.

:class:`LoopState` holds ``frequency``, ``period_ns``, ``iteration`` (-1 before the
first), ``time_ns`` (the scheduled start of the current iteration since the loop
started), ``stamp_ns`` (the same instant in ROS time: ns since the epoch, or /clock
time under use_sim_time) and ``running``. It is part of the hot path (a port's write
reads its iteration), so it comes from :mod:`rtcf._core._hotpath`.
"""

from __future__ import annotations

from ._hotpath import LoopState

__all__ = ["LoopState"]
