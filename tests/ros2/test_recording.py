"""Recording under ROS 2: the custom-message example with --record. The input fed from
ROS (a geometry_msgs/msg/PointStamped) and the outputs are in the MCAP file with their
ROS 2 schemas, read back by rosbags; replayed without ROS, the components write the
same messages again."""

from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import Point, PointStamped
from mcap.reader import make_reader
from nav_msgs.msg import Odometry
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import Header

import rtcf.recording
from rtcf._ros2._msgdef import message_definition
from rtcf._runtime._codec import codec_for
from rtcf._runtime._mcap import McapRecording
from rtcf._runtime._recording import Record, RecordedTopic

from .._proc import interrupt, read_rest, wait_for
from .conftest import start_rtcf
from .test_topics import spin_until

pytestmark = pytest.mark.integration


def test_a_recording_of_ros_inputs_and_message_outputs_replays_without_ros(ros_node, tmp_path):
    path = tmp_path / "pt.mcap"
    proc = start_rtcf(
        "launch", "rtcf_examples", "custom_message.launch.xml", "--middleware", "ros2",
        "--record", path,
    )
    sent = [
        PointStamped(header=Header(frame_id=f"frame {k}"), point=Point(x=k / 3.0, y=-1.0, z=k))
        for k in range(5)
    ]
    try:
        wait_for(proc, "running until Ctrl-C", timeout=60)
        got = []
        ros_node.create_subscription(PointStamped, "/mapped/out", got.append, 10)
        pub = ros_node.create_publisher(PointStamped, "/mapped/in", 10)
        for msg in sent:  # each until it came through: the latest-value input takes it
            assert spin_until(
                ros_node, lambda m=msg: bool(got) and got[-1].header.frame_id
                == m.header.frame_id, timeout=30, publish=lambda m=msg: pub.publish(m)
            )
    finally:
        _, err = interrupt(proc)
    assert proc.returncode == 0, err
    assert f"into {path}; dropped: 0" in err
    store = get_typestore(Stores.ROS2_JAZZY)
    seen = {}
    with AnyReader([Path(path)], default_typestore=store) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        for con, _, raw in reader.messages():
            msg = reader.deserialize(raw, con.msgtype)
            seen.setdefault(con.topic, []).append(msg)
    assert types.pop("/rt_runner/iteration_info") == "std_msgs/msg/Float64MultiArray"
    assert types == {t: "geometry_msgs/msg/PointStamped"
                     for t in ("/mapped/in", "/mapped/tmp", "/mapped/out")}
    # the input as it was fed: one record per message delivered (each was published
    # until it came through, so some more than once), every field
    frames = [m.header.frame_id for m in seen["/mapped/in"]]
    distinct = [f for k, f in enumerate(frames) if k == 0 or frames[k - 1] != f]
    assert distinct == [m.header.frame_id for m in sent]
    xs = {m.header.frame_id: m.point.x for m in seen["/mapped/in"]}
    assert xs == {f"frame {k}": k / 3.0 for k in range(5)}
    # Identity writes when a new value came: the same messages, through the chain
    assert [m.header.frame_id for m in seen["/mapped/out"]] == frames
    # replayed with no middleware at all: the components write the same again
    replay = tmp_path / "replay.mcap"
    result = start_rtcf("replay", path, "--record", replay)
    _, err = read_rest(result, timeout=120)
    assert result.returncode == 0, err
    assert "fed from the recording: /mapped/in" in err

    def cdr(p):
        with open(p, "rb") as f:
            return sorted((c.topic, m.sequence, bytes(m.data))
                          for _, c, m in make_reader(f).iter_messages()
                          if not c.topic.endswith("/iteration_info"))

    assert cdr(replay) == cdr(path)


def test_a_message_with_fixed_size_arrays_is_recorded_and_read_back(tmp_path):
    """rclpy gives fixed-size arrays (Odometry's covariances) as numpy arrays, which
    mcap_ros2's encoder refuses: the recording writes such messages as plain values."""
    codec = codec_for(Odometry)
    out = McapRecording(str(tmp_path / "odom.mcap"), message_definition=message_definition)
    out.begin([RecordedTopic("/odom", "output", "nav_msgs/msg/Odometry", "ros2", 4096, 8)])
    for k in range(3):
        message = Odometry()
        message.pose.pose.position.x = 0.5 * k
        message.pose.covariance = np.arange(36.0) * k
        out.write(Record("/odom", k, k * 1_000_000, codec.encode(message)))
    out.finish({}, {})
    rec = rtcf.recording.read(tmp_path / "odom.mcap")
    assert rec.series("/odom", "pose.pose.position.x").values.tolist() == [0.0, 0.5, 1.0]
    assert rec.series("/odom", "pose.covariance").values[2, 35] == 70.0
