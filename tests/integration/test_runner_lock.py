"""Who may change a running runner: ``lock`` and ``allowed_modules`` (docs/security.md),
on the supervisor every middleware's requests go through."""

import pytest

from rtcf import ComponentSpec, RunnerSettings
from rtcf._runtime._request_fields import RequestRefused
from rtcf._runtime._supervisor import WorkerRunner

from .._proc import rtcf_shm_names

pytestmark = pytest.mark.integration


def _mimo(name: str) -> ComponentSpec:
    return ComponentSpec(name, module="rtcf_examples", class_name="Mimo")


@pytest.mark.parametrize("lock", ["structure", "all"])
def test_a_locked_runner_refuses_structure_once_its_loop_has_run(lock) -> None:
    settings = RunnerSettings(frequency=100.0, lock=lock)
    with WorkerRunner(settings, simulated=True) as runner:
        runner.load(_mimo("a"))  # before the loop: a launch file's components
        runner.load(_mimo("b"))
        assert not runner.locked and runner.live_status().access == (
            f"lock {lock} (applies once the loop runs)")
        runner.run(3)
        assert runner.locked and runner.live_status().access == f"lock {lock} (applies)"
        for refused in (lambda: runner.load(_mimo("c")), lambda: runner.unload("a"),
                        lambda: runner.change_state("a", "deactivate")):
            with pytest.raises(RequestRefused, match=f"runner rt_runner is locked \\(lock "
                                                     f"{lock}\\): it refuses "):
                refused()
        # what a middleware's service asks before it stops the loop for a request
        for what in ("loads", "unloads", "lifecycle transitions"):
            with pytest.raises(RequestRefused, match=f"it refuses {what} while"):
                runner.admits(what)
        if lock == "structure":
            runner.admits("tunables")
        else:
            with pytest.raises(RequestRefused, match="refuses changes of tunable"):
                runner.admits("tunables")
        assert sorted(runner.components) == ["/a", "/b"]  # nothing changed
        assert runner.run(2).iterations == 2  # and the loop goes on
        assert runner.shutdown() == []
    assert rtcf_shm_names() == []


def test_allowed_modules_refuse_a_module_before_it_is_imported() -> None:
    settings = RunnerSettings(frequency=100.0, allowed_modules=("rtcf_examples", r"my_\w+"))
    with WorkerRunner(settings, simulated=True) as runner:
        runner.load(_mimo("a"))
        with pytest.raises(RequestRefused, match=r"module 'os' of '/evil' is not in its "
                                                 r"allowed_modules \(rtcf_examples my_\\w\+\)"):
            runner.load(ComponentSpec("evil", module="os", class_name="system"))
        # a module that does not exist is refused the same way: never imported
        with pytest.raises(RequestRefused, match="not in its allowed_modules"):
            runner.load(ComponentSpec("x", module="rtcf_examples_not", class_name="X"))
        assert sorted(runner.components) == ["/a"]
        runner.admits("loads", "my_robot")
        with pytest.raises(RequestRefused, match="module 'os' is not in its allowed_modules"):
            runner.admits("loads", "os")
        assert runner.live_status().access == r"allowed modules rtcf_examples my_\w+"
        assert runner.shutdown() == []


def test_a_runner_without_a_lock_is_open() -> None:
    with WorkerRunner(RunnerSettings(frequency=100.0), simulated=True) as runner:
        runner.load(_mimo("a"))
        runner.run(2)
        runner.admits("loads", "anything", "/b")
        with pytest.raises(RequestRefused, match="'/a': is already loaded"):
            runner.admits("loads", "rtcf_examples", "/a")  # answered without the worker
        assert not runner.locked and runner.live_status().access == ""
        runner.load(_mimo("b"))
        runner.unload("a")
        assert sorted(runner.components) == ["/b"]
        assert runner.shutdown() == []


@pytest.mark.parametrize("lock, tunable", [("structure", True), ("all", False)])
def test_lock_all_also_refuses_tunables(lock, tunable) -> None:
    with WorkerRunner(RunnerSettings(frequency=100.0, lock=lock), simulated=True) as runner:
        runner.load(ComponentSpec("pid", module="rtcf_examples", class_name="Pid"))
        runner.run(2)
        if tunable:
            assert runner.set_parameter("pid", "kp", 2.5) == 2.5
        else:
            with pytest.raises(RequestRefused, match="refuses changes of tunable parameters"):
                runner.set_parameter("pid", "kp", 2.5)
        runner.set_log_level("pid", "debug")  # a log level is not the robot's behaviour
        assert runner.shutdown() == []


def test_rtcf_check_shows_the_access_and_refuses_what_the_runner_would(tmp_path) -> None:
    import subprocess
    import sys

    def check(allowed: str) -> subprocess.CompletedProcess[str]:
        path = tmp_path / "lock.launch"
        path.write_text(f"""<launch>
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <rosparam param="frequency">100.0</rosparam>
    <rosparam param="lock">"structure"</rosparam>
    <rosparam param="allowed_modules">[{allowed}]</rosparam>
  </node>
  <node name="a" pkg="rtcf" type="rt_launcher" args="rtcf_examples Mimo"/>
</launch>
""")
        return subprocess.run([sys.executable, "-m", "rtcf", "check", str(path)],
                              capture_output=True, text=True, timeout=60,
                              stdin=subprocess.DEVNULL)

    ok = check('"rtcf_examples", "my_robot\\\\..*"')
    assert ok.returncode == 0, ok.stderr
    assert "access: lock structure; allowed modules rtcf_examples my_robot\\..*" in ok.stdout
    refused = check('"my_robot\\\\..*"')
    assert refused.returncode == 1 and "OK" not in refused.stdout
    assert refused.stderr.strip().endswith(
        "lock.launch:2: runner /rt_runner: component /a's module 'rtcf_examples' is not in "
        "its allowed_modules (my_robot\\..*)")
