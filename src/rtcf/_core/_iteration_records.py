"""``iteration_info`` as read back from a recording: one row per recorded iteration.

A runner publishes one ``iteration_info`` message per iteration; a recording of them
(a ROS 1 bag, or an MCAP file: rtcf's own recording or rosbag2's) is what the original's
``evaluate_performance_rosbag`` turned into the paper's Fig. 2. Each recording
format has a reader of its own that returns :class:`IterationRecords`; ``rtcf
evaluate`` (``rtcf._cli._evaluate``) does the rest, whatever the format was.

The rows come in two forms. The original's ``rtcf_msgs/IterationInfo`` carries when
the iteration started (``stamp``) and its calculation time: the wake-up jitter shows
only in the intervals between stamps. The ``std_msgs/Float64MultiArray`` form
(``[iteration, stamp, calc_duration, jitter]``, ROS 2 and ROS 1 without rtcf_msgs)
carries the iteration number and the wake-up jitter itself, and its stamp is the
scheduled start.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt


@dataclass
class IterationRecords:
    """The iteration_info of one topic of a recording, in recording order."""

    source: str  # the file
    topic: str
    msg_type: str  # "rtcf_msgs/IterationInfo", "std_msgs/Float64MultiArray", ...
    stamp_ns: npt.NDArray[np.int64]  # when the iteration started (or was scheduled to)
    calc_ns: npt.NDArray[np.int64]  # its calculation time
    # where the form carries them: the wake-up jitter and the iteration number
    jitter_ns: npt.NDArray[np.int64] | None = None
    iteration: npt.NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return int(self.stamp_ns.size)
