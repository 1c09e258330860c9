"""ROS 1 tests: a real roscore on a free port, rtcf's supervisor in processes of its own.

These run in .venv-ros1 (bash scripts/setup-ros1 sets it up). Without rospy they
fail at import: missing ROS in CI is a failure, not a skip.

rospy allows one node per process, for the life of the process, so every runner
under test is a process of its own (fixtures/rtcf_ros1_runner.py), and this test
process is one more node of the graph: the "separate" publisher and subscriber.
"""

import atexit
import ctypes
import ctypes.util
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import rosgraph
import rospy  # fails loudly where ROS 1 is missing

from .._proc import env_with

FIXTURES = Path(__file__).parent / "fixtures"
# the middleware-free components, some of which both middlewares' tests load
COMMON = Path(__file__).parents[1] / "integration" / "fixtures"


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# a master of its own, on loopback only, so parallel runs on one machine do not meet;
# set at import: rospy and rosgraph read the environment when they are first used
PORT = _free_port()
_HOME = tempfile.mkdtemp(prefix="rtcf-ros1-")
atexit.register(shutil.rmtree, _HOME, ignore_errors=True)
os.environ.update(
    ROS_MASTER_URI=f"http://127.0.0.1:{PORT}",
    ROS_IP="127.0.0.1",
    ROS_HOME=_HOME,
    ROS_LOG_DIR=os.path.join(_HOME, "log"),
)
os.environ.pop("ROS_HOSTNAME", None)
os.environ.pop("ROS_NAMESPACE", None)


def pytest_configure(config):
    # rospy and rosgraph talk XML-RPC through ServerProxy objects that they never close
    config.addinivalue_line("filterwarnings", "ignore:unclosed <socket:ResourceWarning")
    # and call threading's camelCase aliases (notifyAll) from their own threads, where an
    # error would make rospy retry its master registration forever
    config.addinivalue_line(
        "filterwarnings",
        r"ignore:\w+\(\) is deprecated, use \w+\(\) instead:DeprecationWarning",
    )


def rtcf_env():
    env = env_with(FIXTURES, COMMON)
    return env


def start_runner(
    components, *, name="rt_runner", namespace=None, iterations=None, log_level="info",
    **settings,
):
    """A supervisor process with a Ros1Bridge (see fixtures/rtcf_ros1_runner.py)."""
    config = {
        "name": name,
        "namespace": namespace,
        "log_level": log_level,
        "settings": {"mode": "no_wait", "frequency": 100.0, **settings},
        "components": components,
        "iterations": iterations,
    }
    return subprocess.Popen(
        [sys.executable, str(FIXTURES / "rtcf_ros1_runner.py"), json.dumps(config)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=rtcf_env(),
    )


@pytest.fixture(scope="session")
def roscore():
    """roscore (rosmaster and rosout) on PORT, for the whole session."""
    log = open(os.path.join(_HOME, "roscore.out"), "w")
    proc = subprocess.Popen(
        ["roscore", "-p", str(PORT)],
        stdout=log,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        env=dict(os.environ),
        preexec_fn=_own_group_ended_with_us,
    )
    try:
        deadline = time.monotonic() + 30
        while not _rosout_up():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(
                    "roscore did not come up:\n" + Path(log.name).read_text()
                )
            time.sleep(0.1)
        yield os.environ["ROS_MASTER_URI"]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        log.close()


def _own_group_ended_with_us():
    # a group of its own: a Ctrl-C of pytest does not reach it half-way, and killpg
    # reaches rosmaster and rosout too; SIGTERM if pytest dies without its teardown
    os.setsid()
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    libc.prctl(1, signal.SIGTERM, 0, 0, 0)  # PR_SET_PDEATHSIG


def _rosout_up():
    if not rosgraph.is_master_online():
        return False
    try:
        _, subs, _ = rosgraph.Master("/rtcf_test").getSystemState()
    except Exception:
        return False
    return any(topic == "/rosout" for topic, _ in subs)  # the rosout node is there


@pytest.fixture(scope="session")
def ros_node(roscore):
    """This process as a node of the graph (rospy: once per process)."""
    rospy.init_node("rtcf_test", anonymous=True, disable_signals=True)
    yield rospy.get_name()
    rospy.signal_shutdown("tests done")


@pytest.fixture
def topics(ros_node):
    from ._helpers import Topics

    t = Topics()
    try:
        yield t
    finally:
        t.close()
