"""The original's command-line tools under their own names, through rosrun (ros1/rtcf).

component_list, component_info, connection_list, connection_info and component_order
ask the runner /rt_runner (the original's default) or the one --runner names;
evaluate_performance_rosbag reads a real bag, recorded with rosbag record from a
running runner, and plots it.
"""

import json
import subprocess
import time

import numpy as np
import pytest
import rosbag

from .._proc import end_after_each_test, read_rest
from ._launch import end, ros1_env, start
from .test_nodes import STARTED, launcher, runner, sum3

pytestmark = pytest.mark.integration


_end_all = end_after_each_test(STARTED, end, launchers_first=True)


def rosrun(*args, timeout=60):
    out = subprocess.run(
        ["rosrun", "rtcf", *map(str, args)],
        capture_output=True, text=True, env=ros1_env(), timeout=timeout,
        stdin=subprocess.DEVNULL,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout


def test_the_introspection_scripts_under_rosrun(ros_node):
    runner("/rt_runner", ros_mapping_whitelist="/ros/.*")
    sum3("/rt_runner", "")  # /a and /b: /ros/out = 3 * /ros/in, through /mid
    # in the order they were loaded: the two launchers race, so either may come first
    expected = [["/a", "rtcf_examples.Mimo"], ["/b", "rtcf_examples.Mimo"]]
    listing: list[list[str]] = []
    deadline = time.monotonic() + 20
    while sorted(listing) != expected and time.monotonic() < deadline:
        listing = [line.split() for line in rosrun("component_list").splitlines()]
        if sorted(listing) != expected:
            time.sleep(0.5)
    listing = sorted(listing)
    if listing != expected:
        for proc in STARTED:  # what the runner and the launchers said, to tell why
            if proc.poll() is None:
                proc.terminate()
        said = "\n".join(read_rest(p, timeout=30)[1] for p in STARTED)
        raise AssertionError(f"component_list: {listing}\n{said}")
    info = rosrun("component_info", "/b")
    assert info.startswith("/b  (rtcf_examples.Mimo)")
    assert "in1 -> /mid" in info and "in2 -> /ros/in" in info and "out1 -> /ros/out" in info
    rows = [line.split() for line in rosrun("connection_list").splitlines()]
    connections = {row[0]: row[1:] for row in rows}
    assert connections["/mid"] == ["builtins.float"]  # inside the runner only
    assert connections["/ros/out"] == ["builtins.float", "ROS"]
    mid = rosrun("connection_info", "/mid")
    assert "publishers: /a" in mid and "subscribers: /b" in mid and "mapped to ROS: no" in mid
    assert rosrun("component_order").split() == ["1.", "/a", "2.", "/b"]


def test_the_scripts_ask_the_runner_that_runner_names(ros_node):
    runner("/arm/rt_runner")
    launcher("/arm/rt_runner", "only", "Mimo")
    time.sleep(0.5)
    assert rosrun("component_list", "--runner", "/arm/rt_runner").split() == [
        "/only", "rtcf_examples.Mimo"
    ]
    missing = subprocess.run(
        ["rosrun", "rtcf", "component_list", "--timeout", "1"],  # no /rt_runner now
        capture_output=True, text=True, env=ros1_env(), timeout=60,
    )  # fmt: skip
    assert missing.returncode == 1
    assert "no runner answers at /rt_runner/introspect" in missing.stderr


def test_evaluate_performance_rosbag_of_a_recorded_bag(ros_node, tmp_path):
    runner("/rt_runner", frequency=200.0)
    sum3("/rt_runner", "")
    bag_path = tmp_path / "run.bag"
    record = start(
        "rosbag", "record", "-O", bag_path, "/rt_runner/iteration_info", "--duration=3"
    )
    _, err = read_rest(record, timeout=60)
    assert record.returncode == 0, err
    # what the bag holds, read here on its own
    with rosbag.Bag(str(bag_path)) as bag:
        rows = [
            (m.stamp.to_nsec(), m.duration_ns)
            for _, m, _ in bag.read_messages(topics=["/rt_runner/iteration_info"])
        ]
    assert len(rows) > 300, len(rows)  # about 3 s at 200 Hz
    stamps = np.array([r[0] for r in rows])
    durations = np.array([r[1] for r in rows])
    doc = json.loads(rosrun("evaluate_performance_rosbag", bag_path, 200, "--json"))
    assert doc["topic"] == "/rt_runner/iteration_info"
    assert doc["type"] == "rtcf_msgs/IterationInfo"
    assert doc["samples"] == len(rows)
    assert doc["calc_us"]["min"] == durations.min() / 1e3  # min and max are exact
    assert doc["calc_us"]["max"] == durations.max() / 1e3
    assert doc["median_interval_us"] == pytest.approx(5000.0, rel=0.05)
    deviation = np.abs(np.diff(np.sort(stamps)) - 5_000_000)  # every interval counts
    assert doc["starts"] == "|start-to-start interval - period|"
    assert doc["starts_us"]["max"] == deviation.max() / 1e3
    assert doc["starts_us"]["max"] > 0  # the stamps carry the real starts, not the grid
    png = tmp_path / "run.bag.evaluation.png"  # beside the bag, as the original's
    assert doc["plot"] == str(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    text = rosrun("evaluate_performance_rosbag", bag_path, 200, "--output", tmp_path / "f.png")
    assert f"{len(rows):,} iterations on /rt_runner/iteration_info" in text
    assert "calculation" in text and (tmp_path / "f.png").is_file()


@pytest.mark.parametrize("exe", ["rt_runner", "rt_launcher"])
def test_help_prints_the_usage_without_a_master(exe):
    env = {**ros1_env(), "ROS_MASTER_URI": "http://127.0.0.1:9"}  # nothing answers there
    out = subprocess.run(["rosrun", "rtcf", exe, "--help"], capture_output=True, text=True,
                         env=env, timeout=60, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f"usage: {exe} [-h]")
    assert "docs/ros1.md" in out.stdout and "_NAME:=VALUE" in out.stdout
    if exe == "rt_runner":
        assert "\n  frequency " in out.stdout and "~load_component" in out.stdout
