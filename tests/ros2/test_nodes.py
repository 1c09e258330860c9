"""rt_runner and rt_launcher as separate ROS 2 processes, as ros2 run would start them."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rcl_interfaces.msg import Parameter
from rcl_interfaces.srv import SetParametersAtomically
from rclpy.parameter import Parameter as PyParameter

from .._proc import end_after_each_test, wait_for
from .conftest import rtcf_env
from .test_topics import FloatProbe, spin_until

pytestmark = pytest.mark.integration

BIN = Path(sys.executable).parent


STARTED = []


def start(exe, *args):
    proc = subprocess.Popen(
        [str(BIN / exe), *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=rtcf_env(),
    )
    STARTED.append(proc)
    return proc


def runner(name, **params):
    args = ["--ros-args", "-r", f"__node:={name}", "-p", "mode:=no_wait"]
    params.setdefault("frequency", 100.0)
    params.setdefault("ros_mapping_whitelist", "/ros/.*")
    for key, value in params.items():
        args += ["-p", f"{key}:={value}"]
    return start("rt_runner", *args)


def launcher(runner_name, name, cls, *remaps):
    args = ["rtcf_examples", cls, "--ros-args", "-r", f"__node:={name}"]
    for rule in remaps:
        args += ["-r", rule]
    args += ["-p", f"runner:={runner_name}"]
    return start("rt_launcher", *args)


def end(*procs):
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    for p in procs:
        try:
            p.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()


_end_all = end_after_each_test(STARTED, end)


def sum_of_two_launchers(ros_node, runner_name, prefix):
    """Two Mimo launchers: out = 3 * in, as in the SumTest."""
    a = launcher(runner_name, f"{prefix}a", "Mimo", f"in1:=/ros/{prefix}in",
                 f"in2:=/ros/{prefix}in", f"out1:=/{prefix}mid")
    b = launcher(runner_name, f"{prefix}b", "Mimo", f"in1:=/{prefix}mid",
                 f"in2:=/ros/{prefix}in", f"out1:=/ros/{prefix}out")
    wait_for(a, "loaded into")
    wait_for(b, "loaded into")
    probe = FloatProbe(ros_node, f"/ros/{prefix}in", f"/ros/{prefix}out")
    assert probe.answers(7.0, pytest.approx(3 * 7.0)), probe.got[-3:]
    return a, b


def test_runner_and_launchers_as_separate_processes(ros_node):
    r = runner("rt_runner")
    try:
        wait_for(r, "ready")
        a, b = sum_of_two_launchers(ros_node, "/rt_runner", "")
        def names():
            return {n for n, _ in ros_node.get_node_names_and_namespaces()}

        # each component is a node of its own name in the graph
        assert spin_until(ros_node, lambda: {"rt_runner", "a", "b"} <= names(), timeout=30), names()
        end(a)  # a stopped launcher unloads its component
        wait_for(r, "unloaded /a")
        end(b)
        wait_for(r, "unloaded /b")
    finally:
        end(r)
    assert r.returncode == 0


def test_a_malformed_load_request_is_refused_and_the_runner_keeps_running(ros_node):
    r = runner("rt_runner")
    try:
        wait_for(r, "ready")
        client = ros_node.create_client(SetParametersAtomically, "/rt_runner/load_component")
        assert client.wait_for_service(timeout_sec=20)
        req = SetParametersAtomically.Request()
        req.parameters = [
            Parameter(name="module", value=PyParameter("m", value="rtcf_examples")
                      .get_parameter_value()),
            Parameter(name="name", value=PyParameter("n", value="x").get_parameter_value()),
        ]
        future = client.call_async(req)
        assert spin_until(ros_node, future.done)
        result = future.result().result
        assert not result.successful
        assert result.reason == "load_component: missing field(s) class"

        def load(**fields):
            req = SetParametersAtomically.Request()
            req.parameters = [
                Parameter(name=k, value=PyParameter("v", value=v).get_parameter_value())
                for k, v in {"module": "rtcf_examples", "class": "Mimo", "name": "y",
                             **fields}.items()
            ]
            future = client.call_async(req)
            assert spin_until(ros_node, future.done)
            return future.result().result

        # each field type-checked: one line naming the field, what came, what it wants
        for fields, said in (
            ({"remaps": 7}, "field 'remaps' got 7 (int); it wants a list of 'from:=to'"),
            ({"is_first": "yes"}, "field 'is_first' got 'yes' (str); it wants true or false"),
            ({"name": "n" * 5000}, "it wants a name of letters, digits and _ (segments split "
                                   "by /) of at most 255 characters"),
            ({"module": "os.path; import this"}, "it wants a Python module name"),
        ):
            result = load(**fields)
            assert not result.successful and said in result.reason, result.reason
            assert result.reason.startswith("load_component: field ")
        bad = launcher("/rt_runner", "ghost", "NoSuchClass")
        bad.communicate(timeout=60)
        assert bad.returncode == 1
        # still serving: a good launcher works afterwards
        a, b = sum_of_two_launchers(ros_node, "/rt_runner", "")
        end(a, b)
    finally:
        if r.poll() is None:
            r.send_signal(signal.SIGINT)
        _, err = r.communicate(timeout=30)
    assert r.returncode == 0
    assert "Warning" not in err and "Traceback" not in err, err  # nothing leaked


@pytest.fixture
def short_lease(monkeypatch):
    """The processes started in the test announce a participant lease of 3 s: the
    death of one is noticed in seconds, not after Fast DDS' 20 s (docs/ros2.md)."""
    monkeypatch.setenv("FASTRTPS_DEFAULT_PROFILES_FILE",
                       str(Path(__file__).parent / "fixtures" / "short_lease.xml"))


def test_a_killed_launcher_gets_its_component_unloaded(ros_node, short_lease):
    r = runner("rt_runner")
    try:
        wait_for(r, "ready")
        a = launcher("/rt_runner", "lonely", "Mimo", "in1:=/ros/q")
        wait_for(a, "loaded into")
        wait_for(r, "loaded /lonely")
        a.kill()
        a.communicate()
        # noticed when DDS drops the dead participant, after its lease (3 s here)
        t0 = time.monotonic()
        wait_for(r, "unloaded /lonely", timeout=60)
        waited = time.monotonic() - t0
        assert waited < 15, f"noticed after {waited:.1f} s: the lease of 3 s was not used"
    finally:
        end(r)


def launcher_of_a_killed_runner(name):
    """A Mimo launcher loaded into /rt_runner, whose runner then died without a word
    (SIGKILL). The autouse fixture ends what is left."""
    r = runner("rt_runner")
    wait_for(r, "ready")
    a = launcher("/rt_runner", name, "Mimo")
    wait_for(a, "loaded into")
    r.kill()
    r.communicate()
    return a


def test_launchers_of_a_killed_runner_exit_with_a_clear_message(ros_node, short_lease):
    a = launcher_of_a_killed_runner("orphan")
    err = wait_for(a, "is gone", timeout=60)  # after the DDS lease of the dead runner
    assert "the runner /rt_runner is gone" in err
    a.communicate(timeout=20)
    assert a.returncode == 1


def test_two_runners_share_one_graph(ros_node):
    r1 = runner("runner_one")
    r2 = runner("runner_two")
    try:
        wait_for(r1, "ready")
        wait_for(r2, "ready")
        a1, b1 = sum_of_two_launchers(ros_node, "/runner_one", "one_")
        a2, b2 = sum_of_two_launchers(ros_node, "/runner_two", "two_")
        wait_for(r1, "loaded /one_b")
        wait_for(r2, "loaded /two_b")
        end(a1, b1, a2, b2)
    finally:
        end(r1, r2)


def test_a_launchers_node_tunes_its_component_in_the_runner(ros_node):
    """The launcher's node is the component's face: set_parameters and logger levels on it
    reach the worker of its runner."""
    from rcl_interfaces.msg import LoggerLevel
    from rcl_interfaces.srv import SetLoggerLevels, SetParameters

    from .test_parameters import call

    r = runner("tune_runner")
    wait_for(r, "ready", 30)
    args = ["rtcf_ros2_components", "Tuned", "--ros-args", "-r", "__node:=tl",
            "-r", "in:=/ros/tl_in", "-r", "out:=/ros/tl_out",
            "-p", "runner:=/tune_runner", "-p", "gain:=4.0"]
    la = start("rt_launcher", *args)
    wait_for(la, "loaded into", 30)
    probe = FloatProbe(ros_node, "/ros/tl_in", "/ros/tl_out")
    assert probe.answers(2.0, 8.0), probe.got[-3:]
    req = SetParameters.Request(parameters=[
        Parameter(name="gain", value=PyParameter("gain", value=0.5).get_parameter_value())
    ])
    assert call(ros_node, SetParameters, "/tl/set_parameters", req).results[0].successful
    assert probe.answers(2.0, 1.0), probe.got[-3:]
    req = SetParameters.Request(parameters=[
        Parameter(name="mode", value=PyParameter("mode", value="cube").get_parameter_value())
    ])
    result = call(ros_node, SetParameters, "/tl/set_parameters", req).results[0]
    assert not result.successful and "not one of" in result.reason
    levels = SetLoggerLevels.Request(levels=[LoggerLevel(name="tl", level=40)])
    assert call(ros_node, SetLoggerLevels, "/tl/set_logger_levels", levels).results[0].successful


def test_a_launcher_stops_waiting_for_an_unload_once_its_runner_is_gone(ros_node, short_lease):
    # stopped at once, the launcher still finds its runner's unload service (DDS keeps
    # it until the lease ends) and asks: no answer will come
    a = launcher_of_a_killed_runner("stranded")
    a.send_signal(signal.SIGINT)
    _, err = a.communicate(timeout=90)
    # it gave up when the runner left the graph, not after the answer's 60 s
    assert "warning: unload refused: the runner /rt_runner is gone" in err, err
    assert a.returncode == 0


@pytest.mark.parametrize("exe", ["rt_runner", "rt_launcher"])
def test_help_prints_the_usage_and_starts_no_node(exe):
    from rtcf._core._settings import parameter_help

    out = subprocess.run([str(BIN / exe), "--help"], capture_output=True, text=True,
                         env=rtcf_env(), timeout=60, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(f"usage: {exe} [-h]")
    assert "--ros-args" in out.stdout and "docs/ros2.md" in out.stdout
    assert out.stderr == ""  # no node started: no "ready", no ROS log line
    if exe == "rt_runner":  # every runner parameter, and its services
        for name, _, _ in parameter_help():
            assert f"\n  {name} " in out.stdout, name
        assert "~/load_component" in out.stdout
    else:
        assert "MODULE CLASS" in out.stdout and "\n  lane " in out.stdout
    # after --ros-args, -h is not ours: the usage is asked for only before it
    from rtcf._runtime._usage import asks_for_help

    assert not asks_for_help([exe, "--ros-args", "-p", "x:=1", "-h"])


def test_a_locked_runner_keeps_its_components_and_loads_only_allowed_modules(ros_node):
    from diagnostic_msgs.msg import DiagnosticArray

    access = []
    ros_node.create_subscription(
        DiagnosticArray, "/diagnostics",
        lambda m: access.extend(kv.value for s in m.status if s.name == "rtcf: /locked"
                                for kv in s.values if kv.key == "access"), 10)
    r = runner("locked", mode="wait_for_components", num_components_expected=2,
               lock="structure", allowed_modules="rtcf_examples")
    try:
        wait_for(r, "ready")
        a = launcher("/locked", "la", "Mimo")
        b = launcher("/locked", "lb", "Mimo")
        wait_for(a, "loaded into")
        wait_for(b, "loaded into")
        # both loaded, the loop runs, and with it the lock
        assert spin_until(ros_node, lambda: any(v.startswith("lock structure (applies)")
                                                for v in access), timeout=30), access
        assert access[-1] == "lock structure (applies); allowed modules rtcf_examples"
        evil = start("rt_launcher", "os", "system", "--ros-args", "-r", "__node:=evil",
                     "-p", "runner:=/locked")
        _, err = evil.communicate(timeout=60)
        assert evil.returncode == 1
        assert "runner /locked: module 'os' is not in its allowed_modules (rtcf_examples)" in err
        end(a)  # its unload is refused: a locked robot keeps its controller
        _, err = a.communicate(timeout=30)
        assert ("unload refused: runner /locked is locked (lock structure): it refuses "
                "unloads while its loop runs") in err
        end(b)
    finally:
        if r.poll() is None:
            r.send_signal(signal.SIGINT)
        _, err = r.communicate(timeout=30)
    # refused in the service's answer, the loop not stopped for them: the runner's own
    # refusals are only its watch's (the launchers it saw leave keep their components)
    refusals = [line for line in err.splitlines() if "refused" in line]
    assert all("refused unload: runner /locked is locked" in x for x in refusals), err
