"""ROSCONSOLE_CONFIG_FILE sets components' start levels on the embedded default.

The original's logging.launch points the variable at rosconsole_settings.conf with
<env>; here as there, the file's levels decide which records a component makes.
"""

import subprocess
import sys
import textwrap

import pytest

from .._proc import env_with
from .conftest import FIXTURES, run_rtcf

pytestmark = pytest.mark.integration

RUNNER = """
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <rosparam param="mode">"no_wait"</rosparam>
    <rosparam param="frequency">1.0</rosparam>
  </node>"""


def launch_file(tmp_path, conf_text, *, env=True):
    conf = tmp_path / "console.conf"
    conf.write_text(textwrap.dedent(conf_text))
    env_line = f'<env name="ROSCONSOLE_CONFIG_FILE" value="{conf}"/>' if env else ""
    path = tmp_path / "two.launch"
    path.write_text(
        f"<launch>{env_line}{RUNNER}\n"
        '<node name="loud" pkg="rtcf" type="rt_launcher" args="rtcf_examples Logging"/>\n'
        '<group ns="arm"><node name="quiet" pkg="rtcf" type="rt_launcher" '
        'args="rtcf_examples Logging"/></group>\n'
        "</launch>\n"
    )
    return path, conf


def records(stderr, component):
    return {
        line.split("]", 1)[0].lstrip("[")
        for line in stderr.splitlines()
        if f"[{component}]: Test" in line
    }


def test_the_logging_example_shows_debug_records_because_its_file_says_so():
    # --log-level error would hide everything below error; the file sets loggin_test
    # to DEBUG (log4j.logger.ros.rtcf.loggin_test=DEBUG), and the file wins
    result = run_rtcf(
        "launch", "rtcf_examples", "logging.launch", "--sim", "--duration", "2",
        "--log-level", "error",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    err = result.stderr
    assert "rosconsole_settings.conf: component log levels: /loggin_test debug" in err
    assert "[DEBUG] [/loggin_test]: Test non-RT debug with number 12345" in err  # configure
    assert "[DEBUG] #1 [/loggin_test]: Test RT debug at iteration 1" in err
    assert "[INFO] #1 [/loggin_test]: Test RT info at iteration 1" in err


def test_levels_per_component_namespace_and_root_in_the_originals_spelling(tmp_path):
    path, _ = launch_file(
        tmp_path,
        """\
        log4j.logger.ros=ERROR
        log4j.logger.ros.rtcf./loud=DEBUG
        """,
    )
    result = run_rtcf("launch", path, "--sim", "--duration", "2")
    assert result.returncode == 0, result.stderr
    assert records(result.stderr, "/loud") == {"DEBUG", "INFO", "WARNING", "ERROR", "FATAL"}
    assert records(result.stderr, "/arm/quiet") == {"ERROR", "FATAL"}


def test_a_namespace_logger_and_the_process_environment(tmp_path):
    # no <env> in the launch file: the variable comes from rtcf's own environment
    path, conf = launch_file(tmp_path, "log4j.logger.ros.rtcf.arm=WARN\n", env=False)
    env = dict(env_with(FIXTURES), ROSCONSOLE_CONFIG_FILE=str(conf))
    result = subprocess.run(
        [sys.executable, "-m", "rtcf", "launch", str(path), "--sim", "--duration", "2",
         "--log-level", "debug"],
        capture_output=True, text=True, timeout=120, env=env, stdin=subprocess.DEVNULL,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert records(result.stderr, "/arm/quiet") == {"WARNING", "ERROR", "FATAL"}
    assert "DEBUG" in records(result.stderr, "/loud")  # not in /arm: --log-level debug


def test_an_unreadable_file_is_a_warning_and_the_run_goes_on(tmp_path):
    path, conf = launch_file(tmp_path, "")
    conf.unlink()
    result = run_rtcf("launch", path, "--sim", "--duration", "2")
    assert result.returncode == 0, result.stderr
    assert "rtcf: warning: ROSCONSOLE_CONFIG_FILE: cannot read" in result.stderr
    assert records(result.stderr, "/loud") == {"INFO", "WARNING", "ERROR", "FATAL"}
