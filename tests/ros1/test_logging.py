"""Component log records on /rosout (as rqt_console sees them), health on /diagnostics."""

import itertools
import json

import pytest
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Log
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from .._proc import read_rest
from ._helpers import stop, wait_running, wait_until
from .conftest import start_runner

pytestmark = pytest.mark.integration

LOGGING = {"name": "loggin_test", "module": "rtcf_examples", "class": "Logging"}


def test_component_logs_reach_rosout_agg_with_name_and_level(topics):
    # /rosout_agg: what the rosout node of roscore republishes, and rqt_console shows
    records = topics.sub("/rosout_agg", Log, queue_size=1000)
    assert records.connected()
    proc = start_runner([LOGGING], frequency=10.0, iterations=3, log_level="debug")
    _, err = read_rest(proc)
    assert proc.returncode == 0, err
    mine = lambda: [r for r in records if r.name == "/loggin_test"]  # noqa: E731
    assert wait_until(lambda: len(mine()) >= 20), [(r.name, r.msg) for r in records]
    seen = {(r.level, r.msg, r.function) for r in mine()}
    levels = (
        (Log.DEBUG, "debug"), (Log.INFO, "info"), (Log.WARN, "warning"),
        (Log.ERROR, "error"), (Log.FATAL, "fatal"),
    )
    for level, word in levels:
        for i in (0, 1, 2):
            assert (level, f"Test RT {word} at iteration {i}", "update") in seen
        if level != Log.DEBUG:
            assert (level, f"Test non-RT {word} with number 12345", "") in seen
    # the original's rosconsole logger name, where rqt_console shows the location
    assert {r.file for r in mine()} == {"ros.rtcf.loggin_test"}


def test_a_log_level_filters_before_rosout(topics):
    records = topics.sub("/rosout", Log, queue_size=1000)
    proc = start_runner([LOGGING], frequency=10.0, iterations=2, log_level="warning")
    _, err = read_rest(proc)
    assert proc.returncode == 0, err
    mine = lambda: [r for r in records if r.name == "/loggin_test"]  # noqa: E731
    assert wait_until(lambda: any(r.msg.endswith("iteration 1") for r in mine()))
    assert {r.level for r in mine()} == {Log.WARN, Log.ERROR, Log.FATAL}


def test_diagnostics_iteration_info_and_introspection(topics):
    arrays = topics.sub("/diagnostics", DiagnosticArray)
    info = topics.sub("/rt_runner/iteration_info", Float64MultiArray, queue_size=1000)
    scale = {
        "name": "scale",
        "namespace": "/arm",
        "module": "rtcf_ros1_components",
        "class": "Scale",
        "remaps": {"in": "/ros/in3", "out": "/ros/out3"},
    }
    proc = start_runner([scale], frequency=200.0, ros_mapping_whitelist="/ros/.*")
    try:
        wait_running(proc)
        assert wait_until(lambda: len(arrays) >= 2, timeout=15)
        status = arrays[-1].status[0]
        assert status.name == "rtcf: rt_runner"
        assert status.hardware_id == "/rt_runner"
        values = {kv.key: kv.value for kv in status.values}
        assert int(values["iterations"]) > 0
        assert "/arm/scale calc p999 [us]" in values
        assert wait_until(lambda: len(info) >= 10)
        rows = [list(m.data) for m in info[-10:]]
        assert info[-1].layout.dim[0].label == "iteration,stamp,calc_duration,jitter"
        steps = list(itertools.pairwise(rows))
        assert all(b[0] == a[0] + 1 for a, b in steps), rows
        # stamps in s since the epoch: float64 resolves about 0.2 us there
        assert all(b[1] - a[1] == pytest.approx(0.005, abs=1e-6) for a, b in steps), rows
        rospy.wait_for_service("/rt_runner/introspect", timeout=10)
        answer = rospy.ServiceProxy("/rt_runner/introspect", Trigger)()
        assert answer.success
        data = json.loads(answer.message)
        assert "/arm/scale" in json.dumps(data["components"])
    finally:
        if proc.poll() is None:
            stop(proc)
