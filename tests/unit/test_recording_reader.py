"""rtcf.recording: a recording written by rtcf's own writer, read back exactly."""

from __future__ import annotations

import numpy as np
import pytest

import rtcf
import rtcf.recording
from rtcf._runtime._codec import codec_for
from rtcf._runtime._mcap import McapRecording
from rtcf._runtime._recording import Record, RecordedTopic

S = 1_000_000_000  # the first stamp: 1 s of ROS time
P = 2_000_000  # 500 Hz


def write(path, topics, metadata=None, attachments=None):
    """An MCAP file as rtcf launch --record writes it: topic -> (port type, [(iteration,
    value)]), stamped S + iteration x P."""
    out = McapRecording(str(path))
    recorded = []
    for topic, (cls, _) in topics.items():
        codec = codec_for(cls)
        recorded.append(
            RecordedTopic(topic, "output", cls.__name__, codec.kind, codec.max_size, 64)
        )
    out.begin(recorded)
    for topic, (cls, values) in topics.items():
        encode = codec_for(cls).encode
        for iteration, value in values:
            out.write(Record(topic, iteration, S + iteration * P, encode(value)))
    out.finish(metadata or {}, attachments or {})
    return path


@pytest.fixture
def recording(tmp_path):
    return write(
        tmp_path / "run.mcap",
        {
            "/f": (float, [(0, 0.1), (1, -2.5), (3, 1e300)]),
            "/i": (int, [(1, 2**62 + 1), (2, -3)]),
            "/b": (bool, [(0, True), (1, False), (2, True)]),
            "/a": (np.ndarray, [(0, np.array([1.0, 2.0])), (2, np.array([3.0, 4.5]))]),
            "/s": (str, [(0, "hello")]),
        },
        {"launch_file": "x.launch", "frequency_hz": 500.0, "order": ["/c"]},
        {"launch/x.launch": ("application/xml", b"<launch/>")},
    )


def test_the_topics_their_types_and_what_the_file_says_of_the_run(recording) -> None:
    rec = rtcf.recording.read(recording)
    assert rec.topics == ["/a", "/b", "/f", "/i", "/s"]
    assert rec.types == {
        "/a": "std_msgs/msg/Float64MultiArray",
        "/b": "std_msgs/msg/Bool",
        "/f": "std_msgs/msg/Float64",
        "/i": "std_msgs/msg/Int64",
        "/s": "std_msgs/msg/String",
    }
    assert rec.definition("/f") == "float64 data\n"
    assert rec.metadata["launch_file"] == "x.launch"  # strings as they are, the rest JSON
    assert rec.metadata["frequency_hz"] == "500.0" and rec.metadata["order"] == '["/c"]'
    assert rec.attachments == {"launch/x.launch": b"<launch/>"}
    assert (rec.start_ns, rec.end_ns) == (S, S + 3 * P)
    assert [(m.iteration, m.log_time) for m in rec.messages["/i"]] == [(1, S + P), (2, S + 2 * P)]
    assert rec.decoder("/s")(rec.messages["/s"][0].data).data == "hello"


def test_a_series_holds_the_values_exactly_as_written(recording) -> None:
    rec = rtcf.recording.read(recording)
    f = rec.series("/f")
    assert f.values.dtype == np.float64 and f.values.tolist() == [0.1, -2.5, 1e300]
    assert f.iterations.tolist() == [0, 1, 3] and len(f) == 3
    assert f.t_ns.tolist() == [S, S + P, S + 3 * P]
    assert f.t_s.tolist() == [0.0, 0.002, 0.006]  # from the file's first message
    assert (f.topic, f.type_name, f.field, f.labels) == (
        "/f", "std_msgs/msg/Float64", "data", ["data"]
    )
    i = rec.series("/i")
    assert i.values.dtype == np.int64 and i.values.tolist() == [2**62 + 1, -3]
    b = rec.series("/b")
    assert b.values.dtype == np.bool_ and b.values.tolist() == [True, False, True]


def test_an_array_is_one_column_per_element(recording, tmp_path) -> None:
    a = rtcf.recording.read(recording).series("/a")
    assert a.values.shape == (2, 2) and a.values.tolist() == [[1.0, 2.0], [3.0, 4.5]]
    assert a.labels == ["data[0]", "data[1]"] and a.iterations.tolist() == [0, 2]
    ragged = write(tmp_path / "ragged.mcap", {
        "/q": (np.ndarray, [(0, np.array([1.0, 2.0, 3.0])), (1, np.array([4.0]))])
    })
    q = rtcf.recording.read(ragged).series("/q")
    assert q.values.shape == (2, 3) and q.values[0].tolist() == [1.0, 2.0, 3.0]
    assert q.values[1, 0] == 4.0 and np.isnan(q.values[1, 1:]).all()
    # a message's field by its dotted path
    offset = rtcf.recording.read(recording).series("/a", "layout.data_offset")
    assert offset.values.tolist() == [0, 0] and offset.labels == ["layout.data_offset"]


def test_only_the_topics_asked_for(recording) -> None:
    assert rtcf.recording.read(recording, ["/f", "/b"]).topics == ["/b", "/f"]
    assert rtcf.recording.read(str(recording), "/i").topics == ["/i"]
    assert rtcf.recording.read(recording, lambda t: t.startswith("/a")).topics == ["/a"]


def test_iterations_past_two_to_the_32_are_unwrapped(tmp_path) -> None:
    first = 2**32 - 2
    path = write(tmp_path / "long.mcap", {"/x": (int, [(first + k, k) for k in range(4)])})
    x = rtcf.recording.read(path).series("/x")
    assert x.iterations.tolist() == [first, first + 1, first + 2, first + 3]
    assert x.values.tolist() == [0, 1, 2, 3]


def test_what_cannot_be_read_is_one_line_naming_it(recording, tmp_path) -> None:
    rec = rtcf.recording.read(recording)
    with pytest.raises(rtcf.ConfigurationError, match=r"run\.mcap has no topic '/nope'; its "
                       r"topics: /a, /b, /f, /i, /s$"):
        rec.series("/nope")
    with pytest.raises(rtcf.ConfigurationError, match=r"^/f \(std_msgs/msg/Float64\) has no "
                       r"field 'x'; its fields: data$"):
        rec.series("/f", "x")
    with pytest.raises(rtcf.ConfigurationError, match=r"^/s \(std_msgs/msg/String\): data "
                       r"holds no numbers$"):
        rec.series("/s")
    with pytest.raises(rtcf.ConfigurationError, match=r"missing\.mcap: cannot read it: No such"):
        rtcf.recording.read(tmp_path / "missing.mcap")
    (tmp_path / "notes.mcap").write_text("hello")
    with pytest.raises(rtcf.ConfigurationError, match=r"notes\.mcap: not an MCAP file"):
        rtcf.recording.read(tmp_path / "notes.mcap")


POINT_STAMPED = """std_msgs/Header header
geometry_msgs/Point point
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
"""


def test_a_ros2_message_gives_a_field_or_every_number_but_its_header(tmp_path) -> None:
    from mcap_ros2.writer import Writer

    path = tmp_path / "point.mcap"
    with open(path, "wb") as f:  # as rtcf records a ROS 2 message: its definition, CDR
        writer = Writer(f)
        schema = writer.register_msgdef("geometry_msgs/msg/PointStamped", POINT_STAMPED)
        for k in range(3):
            message = {
                "header": {"stamp": {"sec": k, "nanosec": 0}, "frame_id": f"frame {k}"},
                "point": {"x": k / 3.0, "y": -1.0, "z": float(k)},
            }
            writer.write_message("/point", schema, message, log_time=S + k * P,
                                 publish_time=S + k * P, sequence=k)
        writer.finish()
    rec = rtcf.recording.read(path)
    assert rec.types == {"/point": "geometry_msgs/msg/PointStamped"}
    x = rec.series("/point", "point.x")
    assert x.values.tolist() == [0.0, 1 / 3.0, 2 / 3.0] and x.labels == ["point.x"]
    whole = rec.series("/point")
    assert whole.field == "" and whole.labels == ["point.x", "point.y", "point.z"]
    assert whole.values.tolist() == [[k / 3.0, -1.0, float(k)] for k in range(3)]
    assert rec.decoder("/point")(rec.messages["/point"][2].data).header.frame_id == "frame 2"
    with pytest.raises(rtcf.ConfigurationError, match=r"holds no numbers$"):
        rec.series("/point", "header.frame_id")
