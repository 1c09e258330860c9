"""Read a recording of ``rtcf launch --record`` (or ``rtcf replay``) in Python.

The same reader as ``rtcf plot`` and ``rtcf diff``: a topic's numbers over time as
numpy arrays, its messages, and what the file says of the run::

    import rtcf.recording

    rec = rtcf.recording.read("run.mcap")
    rec.types               # {'/cascade/position': 'std_msgs/msg/Float64', ...}
    rec.metadata["order"]   # the run's 'rtcf' record, as the file holds it
    s = rec.series("/cascade/position")
    s.iterations, s.t_s, s.values    # numpy arrays, one row per write

``values`` holds a ``float``, ``int`` or ``bool`` port's values exactly as written
(float64, int64, bool), a float array's elements as columns, or the numbers of a ROS 2
message's field (``rec.series("/point", "point.x")``). ``rec.decoder(topic)`` turns a
message's bytes into the message itself. Needs the ``mcap`` packages: ``pip install
'rtcf[record]'``.
"""

from __future__ import annotations

from ._runtime._recording_reader import Message, Recording, Series, read

__all__ = ["Message", "Recording", "Series", "read"]
