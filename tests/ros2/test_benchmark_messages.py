"""benchmarks/ros_messages.py runs (in --quick mode) in this ROS 2 graph: the three ways
of writing a JointState reach a real rclpy subscriber, and the numbers are written.

No ratio is asserted (timing is claimed from the benchmark's runs, never from a test);
what is checked is that each system ran, that ROS received its messages, and that the
last one of each decodes to the arm's shape: the Serialized one is a JointState whose
bytes rtcf laid out itself and the bridge published as they were.
The subprocesses inherit the test's random ROS_DOMAIN_ID (set by conftest).
"""

import pytest

from .._benchmarks import run_quick

pytestmark = pytest.mark.integration


def test_message_benchmark_runs_quick_and_ros_reads_every_system():
    result, data = run_quick("ros_messages")  # and --quick leaves the recorded results alone
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Serialized / float array: " in result.stdout, result.stdout
    summary = data["summary"]
    assert set(summary) == {"rosidl", "Serialized", "float array"}
    for name, s in summary.items():
        own = s["component_calc_us"]
        assert 0 < own["p50"] <= own["p99"] <= own["max"], (name, own)
        assert s["iterations"] >= 1000, (name, s)
        assert 0 < s["received"] <= s["iterations"], (name, s)
        assert s["last_message_ok"], name
