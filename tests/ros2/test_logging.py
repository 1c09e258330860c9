"""Component log records reach /rosout under the component's logger name."""

import signal

import pytest
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from .conftest import start_rtcf
from .test_topics import spin_until

pytestmark = pytest.mark.integration


def rosout(node) -> list[Log]:
    """What /rosout carries from now on (and what was sent before we joined), as it
    arrives while ``node`` spins."""
    records: list[Log] = []
    qos = QoSProfile(
        depth=1000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    node.create_subscription(Log, "/rosout", records.append, qos)
    return records


def test_component_logs_reach_rosout_with_name_and_severity(ros_node):
    records = rosout(ros_node)
    # runs until the records came: a run that ended before DDS matched this subscriber
    # (seconds on a loaded machine) would deliver none of them
    proc = start_rtcf("launch", "rtcf_examples", "logging.launch", "--middleware", "ros2")
    mine = lambda: [r for r in records if r.name == "loggin_test"]  # noqa: E731
    try:
        came = spin_until(ros_node, lambda: len(mine()) >= 12, timeout=30)
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert came, [(r.name, r.msg) for r in records]
    assert proc.returncode == 0, err
    seen = {(r.level, r.msg) for r in mine()}
    for level, word in ((20, "info"), (30, "warning"), (40, "error"), (50, "fatal")):
        assert (level, f"Test RT {word} at iteration 0") in seen
        assert (level, f"Test RT {word} at iteration 1") in seen
        assert (level, f"Test non-RT {word} with number 12345") in seen
    assert not any(r.level == 10 for r in mine())  # debug is filtered (--log-level info)


def test_timing_summary_on_diagnostics(ros_node):
    from diagnostic_msgs.msg import DiagnosticArray

    arrays = []
    ros_node.create_subscription(DiagnosticArray, "/diagnostics", arrays.append, 10)
    proc = start_rtcf(
        "launch",
        "rtcf_examples",
        "paper_evaluation.launch",
        "--middleware",
        "ros2",
        "--duration",
        "4",
    )
    try:
        assert spin_until(ros_node, lambda: len(arrays) >= 2, timeout=30)
    finally:
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    status = arrays[-1].status[0]
    assert status.name == "rtcf: /rt_runner"
    values = {kv.key: kv.value for kv in status.values}
    assert int(values["iterations"]) > 0
    assert float(values["calc p999 [us]"]) > 0
    assert "/H1 calc p999 [us]" in values and "/R3 calc max [us]" in values
    assert values["access"] == "open: any request on its domain"  # no lock, any module
    assert "iterations" in status.message and "overruns" in status.message
    # the count grows from one summary to the next
    assert int({kv.key: kv.value for kv in arrays[0].status[0].values}["iterations"]) < int(
        values["iterations"]
    )


def test_iteration_info_one_message_per_iteration(ros_node):
    from std_msgs.msg import Float64MultiArray

    infos = []
    ros_node.create_subscription(
        Float64MultiArray, "/rt_runner/iteration_info", infos.append, 1000
    )
    proc = start_rtcf(
        "launch", "rtcf_examples", "paper_evaluation.launch", "--middleware", "ros2",
        "--duration", "3",
    )
    try:
        assert spin_until(ros_node, lambda: len(infos) >= 500, timeout=30)
        now = ros_node.get_clock().now().nanoseconds * 1e-9
    finally:
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert infos[0].layout.dim[0].label == "iteration,stamp,calc_duration,jitter"
    rows = [list(m.data) for m in infos]
    iterations = [int(r[0]) for r in rows]
    # consecutive: reliable and deep enough that none is lost at 2 kHz
    assert iterations == list(range(iterations[0], iterations[0] + len(rows)))
    period = rows[1][1] - rows[0][1]
    assert period == pytest.approx(1 / 2000, abs=1e-6)  # the launch file's 2 kHz
    assert abs(rows[-1][1] - now) < 5.0  # stamps are ROS time, not the monotonic clock
    assert all(0 < r[2] < 0.1 for r in rows)  # calculation durations in seconds
