"""The rtcf command line, run as a user would: real processes, real files."""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from .. import _launches
from .conftest import FIXTURES, SRC, run_rtcf
from .test_worker import bomb

pytestmark = pytest.mark.integration

# those that need ROS 2 messages run in their suite: the diffbot (nav_msgs, tf2_msgs)
# and the bringups (xacro, control_msgs) in tests/ros2/controllers
NEEDS_ROS = {"diffbot.launch", "diffbot_bringup.launch.xml",
             "diffbot_component_bringup.launch.xml", "arm_bringup.launch.xml"}
EXAMPLES = sorted(
    p for p in (SRC / "rtcf_examples" / "launch").iterdir() if p.name not in NEEDS_ROS
)
RUNNER = """
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <rosparam param="mode">"no_wait"</rosparam>
    <rosparam param="frequency">100.0</rosparam>
  </node>"""


def write_launch(tmp_path, body, name="test.launch"):
    return _launches.write_launch(tmp_path, body, RUNNER, name)


def error_line(result):
    lines = [ln for ln in result.stderr.splitlines() if ln.startswith("rtcf: error:")]
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    return lines[0]


@pytest.mark.parametrize("launch", EXAMPLES, ids=lambda p: p.name)
def test_every_example_launch_file_runs(launch):
    result = run_rtcf("launch", launch, "--sim", "--duration", "2")
    assert result.returncode == 0, result.stderr
    assert "rtcf: order: " in result.stderr
    assert " iterations at " in result.stdout


def test_paper_evaluation_runs_in_real_time_in_the_paper_order(tmp_path):
    result = run_rtcf(
        "launch",
        "rtcf_examples",
        "paper_evaluation.launch",
        "--duration",
        "0.5",
        "--report",
        tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert "rtcf: order: /H1 -> /F1 -> /R1 -> /R2 -> /R3" in result.stderr
    assert "ran 1000 iterations at 2000 Hz on the system clock" in result.stdout
    assert "wake-up jitter" in result.stdout and "/R3" in result.stdout
    doc = json.loads((tmp_path / "timing.json").read_text())
    assert doc["iterations"] == 1000
    assert doc["order"] == ["/H1", "/F1", "/R1", "/R2", "/R3"]
    assert set(doc["components"]) == {"/H1", "/F1", "/R1", "/R2", "/R3"}
    for key in ("min", "p50", "p99", "p999", "max"):
        assert doc["jitter_us"][key] >= 0
        assert doc["calc_us"][key] > 0
    assert doc["calc_us"]["min"] <= doc["calc_us"]["p50"] <= doc["calc_us"]["max"]


def test_ros2_xml_gives_the_same_graph_as_the_ros1_file():
    ros1 = run_rtcf("graph", "rtcf_examples", "paper_evaluation.launch")
    ros2 = run_rtcf("graph", "rtcf_examples", "paper_evaluation.launch.xml")
    assert ros1.returncode == 0 and ros2.returncode == 0, ros1.stderr + ros2.stderr
    assert ros1.stdout == ros2.stdout
    assert "order: /H1 -> /F1 -> /R1 -> /R2 -> /R3" in ros1.stdout
    assert "/R3_G2H1: /R3.out1 -> /H1.in1   (not ordered: is_first" in ros1.stdout


def test_graph_formats():
    dot = run_rtcf("graph", "rtcf_examples", "complex_architecture.launch", "--format", "dot")
    assert dot.returncode == 0, dot.stderr
    assert dot.stdout.startswith("digraph rtcf {")
    assert dot.stdout.count(" -> ") == 17
    assert dot.stdout.count("style=dashed") == 3
    mermaid = run_rtcf(
        "graph", "rtcf_examples", "complex_architecture.launch", "--format", "mermaid"
    )
    assert mermaid.stdout.startswith("flowchart LR")
    assert mermaid.stdout.count("-.->") == 3


def test_sim_runs_are_identical_iteration_by_iteration(tmp_path):
    traces = []
    for i in range(2):
        out = tmp_path / f"trace{i}.csv"
        result = run_rtcf(
            "launch",
            "rtcf_examples",
            "sine_cascade.launch",
            "gain:=0.8",
            "--sim",
            "--duration",
            "3",
            "--trace",
            out,
        )
        assert result.returncode == 0, result.stderr
        traces.append(out.read_text())
    assert traces[0] == traces[1]
    rows = traces[0].splitlines()
    assert len(rows) == 1 + 3000  # header, then frequency x duration iterations exactly
    header = rows[0].split(",")
    y = [float(r.split(",")[header.index("/demo/y")]) for r in rows[1:]]
    assert max(y) > 0.1 and min(y) < -0.1  # the plant follows the sine both ways


def test_launch_args_change_the_run(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    run_rtcf(
        "launch", "rtcf_examples", "sine_cascade.launch", "--sim", "--duration", "0.1", "--trace", a
    )
    run_rtcf(
        "launch",
        "rtcf_examples",
        "sine_cascade.launch",
        "gain:=2.0",
        "--sim",
        "--duration",
        "0.1",
        "--trace",
        b,
    )
    assert a.read_text() != b.read_text()


def test_check_accepts_a_good_file():
    result = run_rtcf("check", "rtcf_examples", "complex_architecture.launch")
    assert result.returncode == 0, result.stderr
    assert "OK" in result.stdout and "10 components" in result.stdout


def test_cycle_is_an_error_naming_the_components_and_topics(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="a" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
        <remap from="in_port" to="/x"/><remap from="out_port" to="/y"/>
      </node>
      <node name="b" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
        <remap from="in_port" to="/y"/><remap from="out_port" to="/x"/>
      </node>""",
    )
    for command in ("check", "graph", "launch"):
        result = (
            run_rtcf(command, path, "--sim", "--duration", "1")
            if command == "launch"
            else run_rtcf(command, path)
        )
        assert result.returncode == 1
        line = error_line(result)
        assert "cycle" in line and "/a" in line and "/b" in line
        assert "/x" in line and "/y" in line
        assert "is_first" in line and "topics_ignore_for_graph" in line


def test_missing_module_names_file_line_and_component(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="ctl" pkg="rtcf" type="rt_launcher" args="no_such_module Thing"/>""",
    )
    line = error_line(run_rtcf("check", path))
    assert f"{path}:7:" in line
    assert "'/ctl'" in line and "no_such_module" in line and "PYTHONPATH" in line


def test_missing_class_lists_what_the_module_has(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="ctl" pkg="rtcf" type="rt_launcher" args="rtcf_examples Mimoo"/>""",
    )
    line = error_line(run_rtcf("check", path))
    assert "has no class 'Mimoo'" in line and "Mimo" in line


def test_not_a_component_class(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="x" pkg="rtcf" type="rt_launcher" args="rtcf_test_components NotAComponent"/>""",
    )
    assert "not a subclass of rtcf.Component" in error_line(run_rtcf("check", path))


def test_type_mismatch_names_both_ends(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="src" pkg="rtcf" type="rt_launcher" args="rtcf_test_components IntSource"/>
      <node name="dst" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
        <remap from="in_port" to="/out"/>
      </node>""",
    )
    line = error_line(run_rtcf("check", path))
    assert "/src.out" in line and "/dst.in_port" in line and "int" in line and "float" in line


def test_invalid_whitelist_regex_is_an_error(tmp_path):
    path = tmp_path / "bad.launch"
    path.write_text("""<launch>
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <param name="ros_mapping_whitelist" value="(unclosed"/>
  </node>
</launch>
""")
    line = error_line(run_rtcf("check", path))
    assert f"{path}:2:" in line and "ros_mapping_whitelist" in line and "(unclosed" in line


def test_configure_returning_false(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="f" pkg="rtcf" type="rt_launcher" args="rtcf_test_components FailsConfigure"/>""",
    )
    line = error_line(run_rtcf("launch", path, "--sim", "--duration", "1"))
    assert "'/f'" in line and "configure() returned False" in line


def test_too_few_components_for_wait_for_components(tmp_path):
    path = tmp_path / "few.launch"
    path.write_text("""<launch>
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <param name="mode" value="wait_for_components"/>
    <param name="num_components_expected" value="3"/>
  </node>
  <node name="a" pkg="rtcf" type="rt_launcher" args="rtcf_examples BareMinimum"/>
</launch>
""")
    line = error_line(run_rtcf("launch", path, "--sim", "--duration", "1"))
    assert "never start" in line and "1 of the 3" in line


def test_update_exception_names_component_and_iteration_and_runs_teardown(tmp_path):
    path = write_launch(tmp_path, bomb(7))
    result = run_rtcf("launch", path, "--sim", "--duration", "1")
    assert result.returncode == 1
    line = error_line(result)
    assert "'/bomb'" in line and "ZeroDivisionError" in line and "iteration 7" in line
    assert "Explodes stop hook ran" in result.stderr
    assert "Explodes cleanup hook ran" in result.stderr


def test_debug_shows_the_traceback(tmp_path):
    path = write_launch(
        tmp_path,
        """
      <node name="ctl" pkg="rtcf" type="rt_launcher" args="no_such_module Thing"/>""",
    )
    for args in (("--debug", "check", path), ("check", path, "--debug")):
        result = run_rtcf(*args)
        assert result.returncode != 0
        assert "Traceback" in result.stderr


def test_missing_file_and_bad_arguments():
    line = error_line(run_rtcf("launch", "/nonexistent.launch"))
    assert "/nonexistent.launch" in line and "does not exist" in line
    line = error_line(run_rtcf("launch", "rtcf_examples", "nope.launch"))
    assert "nope.launch" in line
    line = error_line(run_rtcf("launch", "rtcf_examples", "sine_cascade.launch", "typo:=1"))
    assert "typo" in line


def test_ctrl_c_stops_cleanly_and_runs_stop_and_cleanup():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), str(FIXTURES)])
    proc = subprocess.Popen(
        [sys.executable, "-m", "rtcf", "launch", "rtcf_examples", "launcher_and_runner.launch"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        stdin=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 30
    seen = ""
    while "running until Ctrl-C" not in seen and time.monotonic() < deadline:
        seen += proc.stderr.readline()
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, seen + err
    assert "SIGINT: stopping" in err
    assert " iterations at 10 Hz" in out


def test_report_dir_for_sim_run(tmp_path):
    result = run_rtcf(
        "launch",
        "rtcf_examples",
        "paper_example.launch",
        "--sim",
        "--duration",
        "1",
        "--report",
        tmp_path / "r",
    )
    assert result.returncode == 0, result.stderr
    doc = json.loads((tmp_path / "r" / "timing.json").read_text())
    assert doc["simulated"] is True and doc["iterations"] == 1000
    assert doc["order"] == ["/example1", "/example2"]
    assert doc["log_records_dropped"] == 0


def test_parameters_reach_the_component(tmp_path):
    result = run_rtcf(
        "launch", "rtcf_examples", "parameter_handling.launch", "--sim", "--duration", "1"
    )
    assert result.returncode == 0, result.stderr
    assert (
        "int_param=33 double_param=0.56789 size=2 another_private_param=-111222333 "
        "public_param=123.456789"
    ) in result.stderr


def test_logging_levels_filter_in_the_component(tmp_path):
    # logging.launch without its ROSCONSOLE_CONFIG_FILE, which would set the level
    # (test_rosconsole_config.py)
    path = tmp_path / "logging.launch"
    path.write_text(
        (SRC / "rtcf_examples" / "launch" / "logging.launch").read_text().replace(
            '<env name="ROSCONSOLE_CONFIG_FILE"', '<!-- env name="ROSCONSOLE_CONFIG_FILE"'
        ).replace('rosconsole_settings.conf"/>', 'rosconsole_settings.conf" -->')
    )
    assert "<env" not in path.read_text()

    def run_at(level):
        return run_rtcf("launch", path, "--sim", "--duration", "2", "--log-level", level)

    quiet, loud = run_at("error"), run_at("debug")
    assert "Test RT debug at iteration 1" in loud.stderr
    assert "[FATAL] #1 [/loggin_test]: Test RT fatal at iteration 1" in loud.stderr
    assert "Test RT info" not in quiet.stderr and "Test RT error at iteration 1" in quiet.stderr
