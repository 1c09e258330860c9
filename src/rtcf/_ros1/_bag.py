"""Reading ``iteration_info`` back from a ROS 1 bag (``rosbag record``), for ``rtcf evaluate``.

The reader of the ROS 1 bag format, with Debian's ``rosbag`` (python3-rosbag, which
``scripts/setup-ros1`` installs). Messages are read raw and unpacked here, not
deserialized one object at a time: a three-hour recording at 2 kHz holds 21.6
million of them. Both forms of the topic are read: the original's
``rtcf_msgs/IterationInfo`` (``time stamp``, ``uint64 duration_ns``) and the
``std_msgs/Float64MultiArray`` ``[iteration, stamp, calc_duration, jitter]`` that a
runner without rtcf_msgs publishes. The bag needs no generated rtcf_msgs to be read.
"""

from __future__ import annotations

import struct
from array import array
from pathlib import Path
from typing import Any

import numpy as np

from .._core._errors import RtcfError
from .._core._iteration_records import IterationRecords

ITERATION_INFO = "rtcf_msgs/IterationInfo"
ARRAY = "std_msgs/Float64MultiArray"
_INFO = struct.Struct("<IIQ")  # time stamp (secs, nsecs), uint64 duration_ns


def read_iteration_info(path: str | Path, topic: str | None = None) -> IterationRecords:
    """The iteration_info messages of ``topic`` in the bag at ``path``.

    Without ``topic``: the one topic of type rtcf_msgs/IterationInfo (or a
    Float64MultiArray topic named ``.../iteration_info``); several are an error that
    names them.
    """
    try:
        import rosbag
    except ImportError as exc:
        raise RtcfError(
            f"reading a ROS 1 bag needs rosbag ({exc}); on Debian run scripts/setup-ros1 "
            "and use .venv-ros1 (docs/ros1.md)"
        ) from None
    source = str(path)
    if not Path(source).is_file():
        raise RtcfError(f"{source}: no such file")
    try:
        bag = rosbag.Bag(source)
    except Exception as exc:  # ROSBagException, ROSBagUnindexedException, OSError
        raise RtcfError(f"{source}: not a readable ROS 1 bag ({exc})") from None
    with bag:
        topics = {name: t.msg_type for name, t in bag.get_type_and_topic_info().topics.items()}
        chosen = _choose(source, topics, topic)
        kind = topics[chosen]
        if kind == ITERATION_INFO:
            return _read_typed(bag, source, chosen)
        return _read_array(bag, source, chosen)


def _choose(source: str, topics: dict[str, str], topic: str | None) -> str:
    listing = ", ".join(f"{n} ({t})" for n, t in sorted(topics.items())) or "none"
    if topic is not None:
        if topic not in topics:
            raise RtcfError(f"{source} has no topic {topic} (it has: {listing})")
        if topics[topic] not in (ITERATION_INFO, ARRAY):
            raise RtcfError(
                f"{source}: {topic} is {topics[topic]}, not {ITERATION_INFO} or {ARRAY}"
            )
        return topic
    found = [n for n, t in topics.items() if t == ITERATION_INFO]
    if not found:
        found = [n for n, t in topics.items() if t == ARRAY and n.endswith("/iteration_info")]
    if len(found) == 1:
        return found[0]
    if not found:
        raise RtcfError(
            f"{source} holds no iteration_info (its topics: {listing}); record one with "
            "rosbag record /rt_runner/iteration_info"
        )
    raise RtcfError(
        f"{source} holds several iteration_info topics ({', '.join(sorted(found))}); "
        "pick one with --topic"
    )


def _read_typed(bag: Any, source: str, topic: str) -> IterationRecords:
    stamps = array("q")
    calcs = array("q")
    unpack = _INFO.unpack
    for _, raw, _ in bag.read_messages(topics=[topic], raw=True):
        data = raw[1]
        if len(data) != _INFO.size:
            raise RtcfError(
                f"{source}: a message on {topic} has {len(data)} bytes, not the "
                f"{_INFO.size} of {ITERATION_INFO}"
            )
        secs, nsecs, duration = unpack(data)
        stamps.append(secs * 1_000_000_000 + nsecs)
        calcs.append(min(duration, 2**63 - 1))
    return IterationRecords(
        source, topic, ITERATION_INFO,
        np.frombuffer(stamps, dtype=np.int64).copy(),
        np.frombuffer(calcs, dtype=np.int64).copy(),
    )  # fmt: skip


def _read_array(bag: Any, source: str, topic: str) -> IterationRecords:
    columns: list[array[int]] = [array("q") for _ in range(4)]
    for _, raw, _ in bag.read_messages(topics=[topic], raw=True):
        values = raw[4]().deserialize(raw[1]).data  # raw[4]: the bag's own message class
        if len(values) != 4:
            raise RtcfError(
                f"{source}: a message on {topic} has {len(values)} values, not the four of "
                "[iteration, stamp, calc_duration, jitter]"
            )
        iteration, stamp, calc, jitter = values
        columns[0].append(round(iteration))
        columns[1].append(round(stamp * 1e9))
        columns[2].append(round(calc * 1e9))
        columns[3].append(round(jitter * 1e9))
    it, stamp_ns, calc_ns, jitter_ns = (
        np.frombuffer(c, dtype=np.int64).copy() for c in columns
    )
    return IterationRecords(source, topic, ARRAY, stamp_ns, calc_ns, jitter_ns, it)
