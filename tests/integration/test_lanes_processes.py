"""Lanes in worker processes of their own: the values of the sequential run, bit for bit.

Each test runs a shipped example twice with ``rtcf launch --trace``: as it is (one
sequential loop) and with some components moved to other lanes (one worker process
each), and compares every topic's value in every iteration. A lane on logical
execution time gives the same trace under ``--sim`` and in real time. A lane that
fails or dies ends every lane, with one line naming it.
"""

from __future__ import annotations

import csv
import json
import os
import re
import signal
import time
from importlib import resources
from pathlib import Path

import pytest

from .._launches import launcher_xml, let_launch
from .._proc import read_rest, rtcf_shm_names, wait_for_match
from .conftest import run_rtcf
from .test_worker import runner_xml, start, write_launch

pytestmark = pytest.mark.integration

EXAMPLES = Path(str(resources.files("rtcf_examples") / "launch"))


def with_lanes(text: str, lanes: dict[str, str], **replace: str) -> str:
    """The launch text with a ``lane`` parameter in the named nodes."""
    for node, lane in lanes.items():
        text, n = re.subn(
            rf'(<node name="{node}"[^>]*>)', rf'\1<param name="lane" value="{lane}"/>', text
        )
        assert n == 1, node
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


def trace(tmp_path: Path, name: str, text: str, *args: str) -> list[dict[str, str]]:
    launch = tmp_path / f"{name}.launch"
    launch.write_text(text)
    out = tmp_path / f"{name}.csv"
    done = run_rtcf("launch", launch, *args, "--trace", out)
    assert done.returncode == 0, done.stderr
    with open(out) as f:
        rows = _Rows(csv.DictReader(f))
    rows.said = done.stderr
    return rows


def on_time_trace(tmp_path: Path, name: str, text: str, *args: str) -> list[dict[str, str]]:
    """A real-time trace in which no handover came late or was lost. On a loaded
    machine a lane may be kept off its CPU for periods: it then keeps the previous
    value, as it must, and counts it; such a run is tried again (at most three)."""
    for _ in range(3):
        rows = trace(tmp_path, name, text, *args)
        if not re.search(r"\d+ (late|lost|let overruns|releases skipped)\b", rows.said):
            return rows
    raise AssertionError(f"three runs with handovers late or lost:\n{rows.said[-2000:]}")


class _Rows(list):
    said = ""  # the run's stderr: late arrivals are counted there


def assert_same(reference: list[dict[str, str]], lanes: list[dict[str, str]]) -> None:
    assert len(lanes) == len(reference) > 10
    assert list(lanes[0]) == list(reference[0])  # every topic, of every lane
    for k, (a, b) in enumerate(zip(reference, lanes, strict=True)):
        differs = {t: (a[t], b[t]) for t in a if a[t] != b[t]}
        assert not differs, (k, differs, getattr(lanes, "said", "")[-3000:])


FIG1 = (EXAMPLES / "paper_evaluation.launch").read_text()
# G2, the ROS node outside the runner in the paper, as a source inside it: values move
SOURCE = """  <node name="G2" pkg="rtcf" type="rt_launcher" args="rtcf_examples Sine">
    <remap from="out" to="/G2_R2"/><param name="offset" value="0.5"/>
    <param name="amplitude" value="0.25"/><param name="frequency_hz" value="3"/>
  </node>
"""


@pytest.mark.parametrize("clock", ["--sim", "real time"])
def test_fig1_in_two_lanes_gives_the_sequential_values(tmp_path, clock):
    # in real time at 200 Hz: a lane waits up to a period (5 ms) for a value
    text = FIG1.replace('"frequency">2000.0', '"frequency">200.0').replace(
        '"num_components_expected">5', '"num_components_expected">6'
    ).replace("</launch>", SOURCE + "</launch>")
    args = ["--duration", "1"] + ([clock] if clock == "--sim" else [])
    reference = trace(tmp_path, "seq", text, *args)
    run = on_time_trace if clock == "real time" else trace
    split = run(tmp_path, "lanes", with_lanes(text, {"R2": "right", "R3": "right"}), *args)
    assert_same(reference, split)
    assert any(float(r["/R3_G2H1"]) != 0.0 for r in split)  # values that moved


@pytest.mark.parametrize("clock", ["--sim", "real time"])
def test_the_complex_architecture_in_three_lanes_gives_the_sequential_values(tmp_path, clock):
    # its second outputs all write /out2, which nothing reads: one topic each, so that
    # the trace has them all (one written in several lanes is not traced)
    text = re.sub(
        r'(<node name="(node_\d+)"[^>]*>)', r'\1<remap from="out2" to="/\2/out2"/>',
        (EXAMPLES / "complex_architecture.launch").read_text(),
    )
    lanes = {"node_4": "b", "node_5": "b", "node_6": "b", "node_8": "c", "node_9": "c",
             "node_10": "c"}
    args = ["--sim", "--duration", "40"]
    run = trace
    if clock == "real time":  # 40 iterations at 200 Hz rather than at its 1 Hz
        text = text.replace('<rosparam param="frequency">1.0</rosparam>',
                            '<rosparam param="frequency">200.0</rosparam>')
        assert ">200.0<" in text
        args, run = ["--duration", "0.2"], on_time_trace
    reference = trace(tmp_path, "seq", text, *args)
    split = run(tmp_path, "lanes", with_lanes(text, lanes), *args)
    assert_same(reference, split)


@pytest.mark.parametrize("clock", ["--sim", "real time"])
def test_the_cascade_with_its_rates_in_two_lanes_gives_the_sequential_values(tmp_path, clock):
    text = (EXAMPLES / "cascade.launch").read_text()
    args = ["--duration", "0.5", "--sim"]
    run = trace
    if clock == "real time":  # its rates divided by 10: a lane waits up to 5 ms, not 0.5
        for arg, hz in (("frequency", "2000.0"), ("position_rate", "500.0"),
                        ("supervisor_rate", "50.0")):
            old = f'<arg name="{arg}" default="{hz}"/>'
            assert old in text
            text = text.replace(old, f'<arg name="{arg}" default="{float(hz) / 10}"/>')
        args, run = ["--duration", "1"], on_time_trace
    reference = trace(tmp_path, "seq", text, *args)
    split = run(tmp_path, "lanes", with_lanes(text, {"velocity_controller": "inner"}), *args)
    assert_same(reference, split)


# /mpc: 9 ms of CPU in lane mpc, every 4 from 1; its output /y
LET = let_launch(frequency=200.0, name="mpc", cls="Busy", every=4, phase=1, cost_us=9000)


def test_a_let_lane_gives_the_same_values_under_sim_and_in_real_time(tmp_path):
    # 9 ms of CPU every 4 periods of 5 ms: longer than a period, shorter than its window
    sim = trace(tmp_path, "sim", LET, "--sim", "--duration", "1")
    real = on_time_trace(tmp_path, "real", LET, "--duration", "1")
    assert_same(sim, real)
    x = [float(r["/x"]) for r in sim]
    for k, row in enumerate(sim):  # released at 1, 5, 9, ...: /x of r - 1, seen at r + 4
        releases = list(range(1, k - 3, 4))
        want = x[releases[-1] - 1] + 1.0 if releases else None
        assert (float(row["/y"]) if row["/y"] else None) == want, k


# the main lane's hardware interface: its torque in a file, "1" while it runs and "0"
# once its safe stop ran
SAFE_HARDWARE = """
  <node name="hw" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components SafeHardware -f">
    <param name="path" value="{path}"/>
  </node>"""


def _with_safe_hardware(tmp_path, body, runner=None):
    """A launch of SAFE_HARDWARE and ``body``; its path and the torque's file."""
    marker = tmp_path / "torque"
    marker.write_text("1")
    return write_launch(tmp_path, SAFE_HARDWARE.format(path=marker) + body, runner), marker


def _the_one_error(proc, marker):
    """The one error line of a run that failed and stopped every lane through its safe
    stops (the hardware's too), leaving no shared memory behind."""
    _out, err = read_rest(proc, 60)
    assert proc.returncode == 1, err
    errors = [line for line in err.splitlines() if line.startswith("rtcf: error:")]
    assert len(errors) == 1, err
    assert marker.read_text() == "0"  # the main lane's hardware interface stopped safely
    assert rtcf_shm_names() == []
    return errors[0]


FAULT = """
  <node name="ctrl" pkg="rtcf" type="rt_launcher" args="rtcf_fault_components Faulty">
    <param name="at" value="20"/><param name="lane" value="control"/>
  </node>"""


def test_a_component_that_raises_in_a_lane_stops_every_lane_through_safe_stop(tmp_path):
    path, marker = _with_safe_hardware(tmp_path, FAULT)
    proc = start("launch", path, "--duration", "5")
    error = _the_one_error(proc, marker)
    assert "/ctrl" in error and "ZeroDivisionError: boom at iteration 20" in error


LET_OVERRUN = launcher_xml("mpc", "rtcf_examples Busy", every=4, cost_us=25000, lane="mpc")


def test_max_let_overruns_stops_every_lane_through_safe_stop(tmp_path):
    # 25 ms of CPU in windows of 4 periods of 5 ms: every window overruns; the third trips
    path, marker = _with_safe_hardware(tmp_path, LET_OVERRUN, runner_xml(max_let_overruns=2))
    proc = start("launch", path, "--duration", "5")
    error = _the_one_error(proc, marker)
    assert re.search(r"lane 'mpc': watchdog max_let_overruns=2: 3 windows of logical "
                     r"execution time not finished in time, the last released at iteration "
                     r"\d+", error), error

LET_FALLBACK = """
  <node name="src" pkg="rtcf" type="rt_launcher" args="rtcf_examples Sine">
    <remap from="out" to="/x"/>
  </node>
  <node name="mpc" pkg="rtcf" type="rt_launcher" args="rtcf_examples Busy">
    <param name="every" value="4"/><param name="cost_us" value="25000"/>
    <param name="lane" value="plan"/><remap from="in_port" to="/x"/>
    <remap from="out_port" to="/u"/>
    <param name="on_error" value="deactivate"/><param name="fallback" value="backup"/>
  </node>
  <node name="backup" pkg="rtcf" type="rt_launcher" args="rtcf_examples Busy">
    <param name="every" value="4"/><param name="cost_us" value="500"/>
    <param name="lane" value="plan"/><remap from="in_port" to="/x"/>
    <remap from="out_port" to="/u"/>
  </node>"""


def test_past_max_let_overruns_the_components_on_error_policy_applies(tmp_path):
    # an MPC that never fits its window, deactivated after the third overrun; a
    # cheaper planner in its lane takes over, and the run goes on to its end
    path = write_launch(tmp_path, LET_FALLBACK, runner_xml(max_let_overruns=2))
    proc = start("launch", path, "--duration", "2")
    out, err = read_rest(proc, 60)
    assert proc.returncode == 0, err
    assert re.search(
        r"fault: component '/mpc': watchdog max_let_overruns=2: 3 windows of logical "
        r"execution time not finished in time, the last released at iteration \d+; took "
        r"out of the schedule: /mpc; /backup took over its outputs \(fallback\)", err), err
    assert "ran 400 iterations" in out
    # the lane skipped only the releases the MPC overran into: the backup fits
    skipped = re.search(r"lane 'plan': (\d+) releases skipped", err)
    assert skipped is not None and int(skipped.group(1)) <= 6, err


def test_past_max_let_overruns_a_restart_policy_restarts_then_gives_up(tmp_path):
    body = LET_FALLBACK.replace(
        '<param name="on_error" value="deactivate"/><param name="fallback" value="backup"/>',
        '<param name="on_error" value="restart"/><param name="max_restarts" value="2"/>',
    )
    body = body[: body.index('  <node name="backup"')]  # the MPC alone in its lane
    assert "restart" in body and "backup" not in body
    path = write_launch(tmp_path, body, runner_xml(max_let_overruns=1))
    proc = start("launch", path, "--duration", "2")
    out, err = read_rest(proc, 60)
    assert proc.returncode == 0, err
    faults = [line for line in err.splitlines() if line.startswith("rtcf: fault:")]
    # two windows overrun each time: restarted twice, then taken out for good
    assert len(faults) == 3, err
    for line in faults[:2]:
        assert line.endswith("restarted it (on_error restart)"), line
        assert "component '/mpc': watchdog max_let_overruns=1: 2 windows" in line, line
    assert faults[2].endswith("took out of the schedule: /mpc"), faults[2]
    assert "ran 400 iterations" in out

HANG = launcher_xml("slow", "rtcf_fault_components Busy", ms=0.1, hang_at=40, lane="planner")


def test_a_lane_process_that_dies_ends_the_run_with_one_line_naming_it(tmp_path):
    path, marker = _with_safe_hardware(tmp_path, HANG)
    proc = start("launch", path, "--duration", "30", "--debug")
    found = wait_for_match(proc, r"planner \(lock step; pid (\d+), ", 30)
    time.sleep(1.0)  # /slow hangs in its update from iteration 40 (0.2 s)
    os.kill(int(found.group(1)), signal.SIGKILL)
    error = _the_one_error(proc, marker)
    assert "lane 'planner'" in error and "killed by SIGKILL" in error, error
    assert "/slow's update() was running" in error, error


def test_a_recording_of_lanes_is_the_sequential_recording_and_replays_to_itself(tmp_path):
    # every lane records its own topics into the one file: in lock step, under --sim,
    # the file holds the sequential run's messages; with the supervisor on logical
    # execution time too, a replay (in one process) gives the recording again
    text = (EXAMPLES / "cascade.launch").read_text()
    inner = {"velocity_controller": "inner"}
    runs = {"seq": text, "lanes": with_lanes(text, inner),
            "let": with_lanes(text, {**inner, "supervisor": "plan"})}
    files = {}
    for name, launch in runs.items():
        path = tmp_path / f"{name}.launch"
        path.write_text(launch)
        files[name] = tmp_path / f"{name}.mcap"
        done = run_rtcf("launch", path, "--sim", "--duration", "0.2", "--record", files[name])
        assert done.returncode == 0, done.stderr
    reference, split = messages(files["seq"]), messages(files["lanes"])
    assert len(reference) > 400
    # the loop's timing, one row an iteration (from the first lane's start to the last
    # one's end), as without lanes
    assert iteration_infos(files["lanes"]) == iteration_infos(files["seq"]) == list(range(400))
    assert {"/cascade/torque", "/cascade/velocity_setpoint"} < {t for t, *_ in split}
    assert split == reference
    let = messages(files["let"])
    assert {t for t, *_ in let} == {t for t, *_ in reference}
    assert let != reference  # the supervisor's outputs are seen one window later
    done = run_rtcf("replay", files["let"])
    assert done.returncode == 0, done.stderr
    assert messages(tmp_path / "let.replay.mcap") == let


def iteration_infos(path: Path) -> list[int]:
    """The iterations of the recorded ~/iteration_info messages."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return [m.sequence for _, c, m in make_reader(f).iter_messages()
                if c.topic.endswith("/iteration_info")]


def messages(path: Path) -> list[tuple[str, int, int, bytes]]:
    """(topic, iteration, log time, bytes) of every recorded value, in a stable order."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return sorted(
            (c.topic, m.sequence, m.log_time, bytes(m.data))
            for _, c, m in make_reader(f).iter_messages()
            if not c.topic.endswith("/iteration_info")  # timing differs by lane
        )


def test_a_report_of_lanes_has_each_lanes_timing(tmp_path):
    launch = tmp_path / "let.launch"
    launch.write_text(LET)
    done = run_rtcf("launch", launch, "--duration", "1", "--report", tmp_path / "r")
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "r" / "timing.json").read_text())
    lanes = doc["lanes"]
    assert set(lanes) == {"main", "mpc"}
    mpc = lanes["mpc"]
    assert mpc["every"] == 4 and mpc["let_window_us"] == pytest.approx(20_000)
    assert 40 <= mpc["iterations"] <= 51  # releases at 1, 5, 9, ... of 200 iterations
    assert 9_000 <= mpc["calc_us"]["p50"] < 20_000  # 9 ms of CPU in each window
    assert mpc["let_margin_us"]["p50"] == pytest.approx(20_000 - mpc["calc_us"]["p50"])
    assert mpc["let_overruns"] == {"/mpc": mpc["overruns"]}
    assert "/mpc" in mpc["components"] and "/mpc" not in lanes["main"]["components"]
    # the top level: the loop as a whole (here the main lane: the other is on LET),
    # and every lane's components (for measured costs)
    assert {"/src", "/sink", "/mpc"} <= set(doc["components"])
    assert doc["calc_us"]["p50"] < 5_000 and doc["iterations"] == 200
    assert doc["calc_us"]["max"] == pytest.approx(lanes["main"]["calc_us"]["max"])
    png = tmp_path / "r" / "timing.png"
    if png.exists():  # matplotlib installed: the loop's panels, then a row per lane
        from matplotlib import image

        assert abs(image.imread(png).shape[0] - (4.5 + 2 * 3.6) * 110) <= 3


EXTRA = """  <node name="extra" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
    <remap from="in_port" to="/cascade/velocity"/><remap from="out_port" to="/extra"/>{lane}
  </node>
</launch>"""


def test_a_load_between_runs_keeps_the_sequential_values(tmp_path):
    # the motor reads the torque of the iteration before from the velocity controller
    # in lane "inner"; a load into a new lane between two runs lays the handovers out
    # anew, and the first delayed read after it still gets the value the last
    # iteration left, as the sequential run does (recorded, not traced: a trace has
    # the main lane receive every topic after each iteration, which would hide it)
    from rtcf._launch._files import load_deployment
    from rtcf._runtime._mcap import McapRecording
    from rtcf._runtime._supervisor import WorkerRunner

    text = (EXAMPLES / "cascade.launch").read_text()
    recorded = {}
    for name, lanes, lane in (("seq", {}, ""),
                              ("lanes", {"velocity_controller": "inner"},
                               '\n    <param name="lane" value="extra"/>')):
        path = tmp_path / f"{name}.launch"
        launch = with_lanes(text, lanes).replace("</launch>", EXTRA.format(lane=lane))
        path.write_text(launch.replace('"mode" value="wait_for_components"',
                                       '"mode" value="no_wait"'))
        deployment = load_deployment([str(path)])
        target = deployment.runner
        specs = {s.full_name: s for s in target.components}
        extra = specs.pop("/extra")
        record = McapRecording(str(tmp_path / f"{name}.mcap"))
        with WorkerRunner(target.settings, parameters=deployment.parameters,
                          simulated=True) as runner:
            for spec in specs.values():
                runner.load(spec)
            runner.run(300, record=record)  # the torque is no longer saturated here
            runner.load(extra)
            runner.run(50, record=record)
            assert runner.shutdown() == []
        record.finish({}, {})
        recorded[name] = messages(tmp_path / f"{name}.mcap")
    assert len(recorded["seq"]) > 1000
    assert recorded["lanes"] == recorded["seq"]
