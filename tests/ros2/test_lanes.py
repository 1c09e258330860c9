"""Lanes under ROS 2: a launcher's ``-p lane:=NAME`` puts its component in a worker
process of its own; its mapped outputs are published, and a mapped input that
components in several lanes read reaches each of them."""

import re
import signal

import pytest
from std_msgs.msg import Int64

from .._proc import read_rest, wait_for
from . import test_lifecycle, test_parameters
from ._clock import clock_publisher, step_clock
from .conftest import start_rtcf
from .test_node_args import CLOCKED
from .test_nodes import STARTED, end, runner, start
from .test_topics import FloatProbe, launched, spin_until, wait_running
from .test_topics import stop as stop_rtcf

pytestmark = pytest.mark.integration


def lane_launcher(name, lane, *remaps):
    args = ["rtcf_examples", "Mimo", "--ros-args", "-r", f"__node:={name}",
            "-p", "runner:=/lane_runner"]
    if lane:
        args += ["-p", f"lane:={lane}"]
    for rule in remaps:
        args += ["-r", rule]
    return start("rt_launcher", *args)


def test_a_lane_publishes_its_outputs_and_reads_what_ros_publishes(ros_node):
    r = runner("lane_runner")
    try:
        wait_for(r, "ready")
        # /ros/lin: read in the main lane (a) and in lane "right" (b); /ros/lout: b's
        a = lane_launcher("la", "", "in1:=/ros/lin", "in2:=/ros/lin", "out1:=/lmid")
        wait_for(a, "loaded into")
        b = lane_launcher("lb", "right", "in1:=/lmid", "in2:=/ros/lin", "out1:=/ros/lout")
        wait_for(b, "loaded into")
        probe = FloatProbe(ros_node, "/ros/lin", "/ros/lout")
        for x in (7.0, -2.5):
            assert probe.answers(x, pytest.approx(3 * x)), probe.got[-3:]
        end(b)
        wait_for(r, "unloaded /lb")
        end(a)
        wait_for(r, "unloaded /la")
        r.send_signal(signal.SIGINT)
        _, err = read_rest(r)
    finally:
        end(*STARTED)
        STARTED.clear()
    assert r.returncode == 0, err
    assert re.search(r"loaded /lb \(rtcf_examples.Mimo\) in lane 'right' \(pid \d+, ", err), err


def test_lanes_follow_clock_with_use_sim_time(ros_node, tmp_path):
    # one echo in the main lane, one in a lock-step lane, one every 3 iterations from
    # phase 1 in a lane of its own (logical execution time): all on /clock time
    params = tmp_path / "clocked.yaml"
    params.write_text(CLOCKED)
    got = {k: [] for k in ("main", "right", "plan")}
    for k, values in got.items():
        ros_node.create_subscription(
            Int64, f"/ros/{k}_it", lambda m, v=values: v.append(m.data), 100
        )
    pub = clock_publisher(ros_node)
    r = start("rt_runner", "--ros-args", "-r", "__node:=clock_lanes", "--params-file", params)
    try:
        wait_for(r, "ready: 10 Hz")
        for k, extra in (("main", []), ("right", ["-p", "lane:=right"]),
                         ("plan", ["-p", "lane:=plan", "-p", "every:=3", "-p", "phase:=1"])):
            echo = start("rt_launcher", "rtcf_ros2_components", "TimeEcho", "--ros-args",
                         "-r", f"__node:={k}_echo", "-p", "runner:=/clock_lanes", *extra,
                         "-r", f"iteration:=/ros/{k}_it", "-r", f"time:=/ros/{k}_t")
            wait_for(echo, "loaded into")
        for k in got:
            assert spin_until(ros_node, lambda k=k: ros_node.count_publishers(f"/ros/{k}_it") > 0)
        step_clock(ros_node, pub, got["main"], periods=10)  # 1 s of /clock
        assert got["main"] == got["right"] == list(range(11)), got
        assert got["plan"] == [1, 4, 7, 10], got
        r.send_signal(signal.SIGINT)  # /clock has stopped: every lane still ends
        _, err = read_rest(r)
    finally:
        end(*STARTED)
        STARTED.clear()
    assert r.returncode == 0, err


@pytest.fixture
def tuned_in_a_lane(tmp_path):
    text = test_parameters.LAUNCH.replace(
        '<param name="gain" value="2.0"/>',
        '<param name="gain" value="2.0"/>\n      <param name="lane" value="tuning"/>',
    )
    assert 'value="tuning"' in text
    with launched(tmp_path / "tuned.launch", text=text) as proc:
        yield proc


def test_a_components_parameters_and_logger_level_in_a_lane(ros_node, tuned_in_a_lane):
    # as in the main lane: the value set reaches the lane's worker between iterations,
    # the level filters there, and its mapped output comes from the lane
    test_parameters.test_a_parameter_set_while_running_changes_the_output(
        ros_node, tuned_in_a_lane
    )
    test_parameters.test_a_logger_level_change_filters_in_the_worker(ros_node, tuned_in_a_lane)


def test_a_lifecycle_round_trip_of_a_component_in_a_lane(ros_node, tmp_path):
    text = test_lifecycle.LAUNCH.replace(
        '<remap from="out1" to="/ros/lc_out"/>',
        '<remap from="out1" to="/ros/lc_out"/>\n      <param name="lane" value="relay"/>',
    )
    assert 'value="relay"' in text
    path = tmp_path / "lc.launch"
    path.write_text(text)
    watch = test_lifecycle.Watch(ros_node, "/ros/lc_out", "/lc/relay")
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    try:
        said = wait_running(proc)
        test_lifecycle.round_trip(ros_node, "/lc/relay", watch)
    finally:
        _, err = stop_rtcf(proc)
    assert "relay (lock step; pid" in said + err
    assert "[/lc/relay]: lifecycle: deactivate: active -> inactive" in err
