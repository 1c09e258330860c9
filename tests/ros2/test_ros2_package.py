"""rtcf as a ROS 2 package, installed as ROS 2 users install it (docs/ros2.md, "Installing").

* pip: a wheel installed into a fresh venv registers rtcf in that prefix's ament index
  and puts rt_runner and rt_launcher into <prefix>/lib/rtcf/, which run that venv's
  Python; the editable install of this venv (scripts/test) does the same, and its
  lib/rtcf/rt_runner serves its services in a real graph.
* colcon: `colcon build` (and `--symlink-install`) of rtcf and the example user package
  examples/ros2_ws/src/my_controllers in a temporary workspace; with its setup.bash
  sourced, the built install/rtcf/lib/rtcf/rt_runner serves its services and runs a
  PidController of my_controllers loaded by install/rtcf/lib/rtcf/rt_launcher, checked
  from this (separate) rclpy process, and `rtcf launch my_controllers
  cascade.launch.xml` finds the launch file through the ament index.

`ros2 run` and `ros2 launch` are not among the PyPI wheels: the look-ups they make
(ros2pkg/ros2run's get_executable_paths, launch_ros's ExecutableInPackage,
ros2launch's get_share_file_path_from_package) are made here with the real
ament_index_python. Missing ROS packages or colcon fail these tests (no skip).
"""

import csv
import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import tomllib
from ament_index_python.packages import (  # fails loudly where the wheel is missing
    get_package_prefix,
    get_package_share_directory,
)
from rcl_interfaces.msg import Parameter
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter as PyParameter
from std_msgs.msg import Float64

from rtcf._launch._substitutions import find_package

from .._proc import read_rest, wait_for
from .test_nodes import end
from .test_parameters import call
from .test_topics import spin_until

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ros2_ws" / "src" / "my_controllers"
BIN = Path(sys.executable).parent
PY = f"python{sys.version_info.major}.{sys.version_info.minor}"
# what a build or a run leaves in a source tree: not part of the project
_NOT_SOURCES = {"build", "install", "log", "dist", "report", "demo-report", "__pycache__"}


def copy_sources(source: Path, dest: Path) -> Path:
    """Copy a project as a clone would have it (no venvs, caches or build output)."""

    def ignore(directory, names):
        return {
            n for n in names
            if n.startswith(".") or n in _NOT_SOURCES or n.endswith(".egg-info")
        }

    shutil.copytree(source, dest, ignore=ignore, symlinks=True)
    return dest


def ros2_run_lookup(package, executable):
    """What `ros2 run PACKAGE EXECUTABLE` runs (ros2run.api.get_executable_path)."""
    base = os.path.join(get_package_prefix(package), "lib", package)
    found = []
    for dirpath, dirnames, filenames in os.walk(base):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        for name in sorted(filenames):
            path = os.path.join(dirpath, name)
            if os.access(path, os.X_OK) and name == executable:
                found.append(path)
    assert len(found) == 1, f"ros2 run {package} {executable}: {found or 'not found'}"
    # launch_ros's ExecutableInPackage: `which` in <prefix>/lib/<package>
    assert shutil.which(executable, path=base) == found[0]
    return found[0]


def ros2_launch_lookup(package, file_name):
    """The file `ros2 launch PACKAGE FILE` reads (get_share_file_path_from_package)."""
    share = get_package_share_directory(package)
    found = [
        os.path.join(root, name)
        for root, _, files in os.walk(share)
        for name in files
        if name == file_name
    ]
    assert len(found) == 1, f"ros2 launch {package} {file_name}: {found or 'not found'}"
    return found[0]


def run(cmd, **kwargs):
    done = subprocess.run(
        [str(c) for c in cmd], capture_output=True, text=True, stdin=subprocess.DEVNULL,
        **kwargs,
    )
    assert done.returncode == 0, f"{cmd} failed:\n{done.stdout}\n{done.stderr}"
    return done


def start(cmd, env):
    return subprocess.Popen(
        [str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL, text=True, env=env,
    )


def test_the_manifests_are_what_colcon_and_rosdep_read():
    """catkin_pkg (what colcon-ros parses package.xml with) accepts both manifests."""
    from catkin_pkg.package import parse_package

    rtcf = parse_package(str(ROOT / "package.xml"))
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert (rtcf.name, rtcf.version, rtcf.package_format) == ("rtcf", version, 3)
    assert rtcf.get_build_type() == "ament_python"
    user = parse_package(str(EXAMPLE / "package.xml"))
    assert (user.name, user.package_format, user.get_build_type()) == (
        "my_controllers", 3, "ament_python")
    assert "rtcf" in {d.name for d in user.exec_depends}


def test_a_pip_install_into_a_fresh_venv_registers_rtcf(tmp_path, monkeypatch):
    source = copy_sources(ROOT, tmp_path / "rtcf")
    user = copy_sources(EXAMPLE, tmp_path / "my_controllers")
    venv = tmp_path / "venv"
    alone = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # the venv alone
    run([sys.executable, "-m", "venv", venv], env=alone)
    pip = [venv / "bin" / "python", "-m", "pip"]
    run([*pip, "install", "--quiet", source, user], env=alone, timeout=600)

    monkeypatch.setenv("AMENT_PREFIX_PATH", str(venv))
    assert get_package_prefix("rtcf") == str(venv)
    share = Path(get_package_share_directory("rtcf"))
    assert ET.parse(share / "package.xml").getroot().findtext("name") == "rtcf"
    for exe in ("rt_runner", "rt_launcher"):
        path = Path(ros2_run_lookup("rtcf", exe))
        assert path == venv / "lib" / "rtcf" / exe
        # it runs the console script of the same prefix, whose first line is the
        # venv's Python, whatever PATH says: rtcf of the venv starts (and stops at
        # the missing rclpy: this venv has no ROS 2)
        assert str(venv / "bin" / "python") in (venv / "bin" / exe).read_text()
        env = {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/")}
        done = subprocess.run([str(path)], capture_output=True, text=True, env=env,
                              stdin=subprocess.DEVNULL, timeout=60)
        assert done.returncode != 0
        assert f"{venv}/lib/{PY}/site-packages/rtcf/" in done.stderr, done.stderr
        assert "ModuleNotFoundError" in done.stderr, done.stderr

    # rtcf's own look-up needs no AMENT_PREFIX_PATH for what pip put into its prefix
    env = {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/")}
    checked = run([venv / "bin" / "rtcf", "check", "my_controllers", "cascade.launch.xml"],
                  env=env)
    launch_file = venv / "share" / "my_controllers" / "launch" / "cascade.launch.xml"
    assert checked.stdout.startswith(f"{launch_file}: OK"), checked.stdout

    # and pip takes all of it away again
    run([*pip, "uninstall", "--yes", "rtcf"], env=alone)
    assert not (venv / "lib" / "rtcf").exists()
    assert not (venv / "share" / "rtcf").exists()
    assert not (venv / "share" / "ament_index" / "resource_index" / "packages" / "rtcf").exists()


def test_the_rt_runner_of_this_venvs_install_serves_in_a_graph(ros_node, monkeypatch):
    """This venv's own (editable) install: lib/rtcf/rt_runner, as ros2 run would start it."""
    monkeypatch.setenv("AMENT_PREFIX_PATH", sys.prefix)
    exe = ros2_run_lookup("rtcf", "rt_runner")
    assert exe == os.path.join(sys.prefix, "lib", "rtcf", "rt_runner"), (
        "reinstall rtcf into this venv (pip install -e '.[test,ros2]')")
    # rtcf's own look-up finds it in this Python's prefix without AMENT_PREFIX_PATH
    assert find_package("rtcf", environ={}) == os.path.join(sys.prefix, "share", "rtcf")
    env = dict(os.environ, PATH="/usr/bin:/bin")  # not this venv's bin/
    name = f"pip_runner_{os.getpid()}"
    r = start([exe, "--ros-args", "-r", f"__node:={name}", "-p", "mode:=no_wait"], env)
    try:
        wait_for(r, "ready", 60)
        want = {f"/{name}/load_component", f"/{name}/unload_component"}
        assert spin_until(
            ros_node,
            lambda: want <= {n for n, _ in ros_node.get_service_names_and_types()},
            timeout=30,
        )
    finally:
        end(r)
    assert r.returncode == 0, read_rest(r)


def sourced(setup_bash, env):
    """The environment that `source install/setup.bash` gives."""
    done = run(["bash", "-c", f'source "{setup_bash}" && env -0'], env=env)
    return dict(line.split("=", 1) for line in done.stdout.split("\0") if "=" in line)


@pytest.mark.parametrize("mode", ["install", "symlink-install"])
def test_colcon_builds_rtcf_and_a_user_package(tmp_path, ros_node, monkeypatch, mode):
    colcon = BIN / "colcon"
    assert colcon.exists(), "colcon is missing: pip install -e '.[test,ros2]'"
    ws = tmp_path / "ws"
    copy_sources(ROOT, ws / "src" / "rtcf")  # as cloned into a workspace
    copy_sources(EXAMPLE, ws / "src" / "my_controllers")
    base = {k: v for k, v in os.environ.items()
            if k not in ("AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH", "PYTHONPATH")}
    t0 = time.monotonic()
    args = ["--symlink-install"] if mode == "symlink-install" else []
    done = run([colcon, "build", *args], cwd=ws, env=base, timeout=600)
    print(f"colcon build {' '.join(args)}: {time.monotonic() - t0:.1f} s")
    # my_controllers after rtcf (its exec_depend), and exactly these two packages: not
    # ros1/rtcf, ros1/rtcf_msgs or src/rtcf_examples (catkin packages of ROS 1)
    out = done.stdout
    assert out.index("Finished <<< rtcf") < out.index("Starting >>> my_controllers"), out
    assert sorted(p.name for p in (ws / "install").iterdir() if p.is_dir()) == [
        "my_controllers", "rtcf"]
    log = (ws / "log" / "latest_build" / "logger_all.log").read_text()
    assert "doesn't explicitly install" not in log  # marker and manifest are rtcf's own

    env = sourced(ws / "install" / "setup.bash", base)
    prefix = ws / "install" / "rtcf"
    monkeypatch.setenv("AMENT_PREFIX_PATH", env["AMENT_PREFIX_PATH"])
    assert get_package_prefix("rtcf") == str(prefix)
    runner_exe = ros2_run_lookup("rtcf", "rt_runner")
    launcher_exe = ros2_run_lookup("rtcf", "rt_launcher")
    assert runner_exe == str(prefix / "lib" / "rtcf" / "rt_runner")
    launch_file = ros2_launch_lookup("my_controllers", "cascade.launch.xml")
    assert launch_file == str(
        ws / "install" / "my_controllers" / "share" / "my_controllers" / "launch"
        / "cascade.launch.xml")
    # the workspace's rtcf and my_controllers, not this venv's rtcf (editable from src/)
    where = run([sys.executable, "-c", "import rtcf, my_controllers; "
                 "print(rtcf.__file__); print(my_controllers.__file__)"], env=env)
    rtcf_file, user_file = where.stdout.split()
    built_in = ws / ("build" if mode == "symlink-install" else "install")
    assert rtcf_file.startswith(str(built_in / "rtcf")), rtcf_file
    assert user_file.startswith(str(built_in / "my_controllers")), user_file
    rtcf_cli = shutil.which("rtcf", path=env["PATH"])
    assert rtcf_cli == str(prefix / "bin" / "rtcf")

    # rtcf launch PACKAGE FILE finds the file where ros2 launch does, and runs it
    checked = run([rtcf_cli, "check", "my_controllers", "cascade.launch.xml"], env=env)
    assert checked.stdout.startswith(f"{launch_file}: OK"), checked.stdout
    trace = tmp_path / "trace.csv"
    run([rtcf_cli, "launch", "my_controllers", "cascade.launch.xml", "--sim",
         "--duration", "5", "--trace", trace], env=env, timeout=120)
    with trace.open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 5000
    tracking = max(abs(float(r["/arm/reference"]) - float(r["/arm/position"]))
                   for r in rows[2000:])
    assert tracking < 0.1, tracking  # the cascade follows its 0.5 amplitude sine

    # the built rt_runner and rt_launcher as ros2 run starts them, PATH without bin/
    env["PATH"] = os.pathsep.join(p for p in env["PATH"].split(os.pathsep)
                                  if p not in (str(prefix / "bin"), str(BIN)))
    name = f"ws_runner_{os.getpid()}"
    r = start([runner_exe, "--ros-args", "-r", f"__node:={name}", "-p", "mode:=no_wait",
               "-p", "frequency:=200.0", "-p", "ros_mapping_whitelist:=/ws/.*"], env)
    pid = None
    try:
        wait_for(r, "ready", 60)
        want = {f"/{name}/load_component", f"/{name}/unload_component",
                f"/{name}/activate_rt_loop", f"/{name}/deactivate_rt_loop"}
        assert spin_until(
            ros_node,
            lambda: want <= {n for n, _ in ros_node.get_service_names_and_types()},
            timeout=30,
        ), sorted(n for n, _ in ros_node.get_service_names_and_types())
        pid = start([launcher_exe, "my_controllers", "PidController", "--ros-args",
                     "-r", "__node:=ws_pid", "-p", f"runner:=/{name}", "-p", "kp:=2.0",
                     "-r", "setpoint:=/ws/setpoint", "-r", "measured:=/ws/measured",
                     "-r", "command:=/ws/command"], env)
        wait_for(pid, "loaded into", 60)
        got = []
        ros_node.create_subscription(Float64, "/ws/command", lambda m: got.append(m.data), 10)
        setpoint = ros_node.create_publisher(Float64, "/ws/setpoint", 10)
        measured = ros_node.create_publisher(Float64, "/ws/measured", 10)

        def publish():
            setpoint.publish(Float64(data=1.0))
            measured.publish(Float64(data=0.25))

        # command = kp * (setpoint - measured)
        assert spin_until(ros_node, lambda: bool(got) and got[-1] == pytest.approx(1.5),
                          timeout=30, publish=publish), got[-3:]
        # kp is tunable on the launcher's node, as on any ROS 2 node
        req = SetParameters.Request(parameters=[
            Parameter(name="kp", value=PyParameter("kp", value=4.0).get_parameter_value())])
        assert call(ros_node, SetParameters, "/ws_pid/set_parameters", req).results[0].successful
        assert spin_until(ros_node, lambda: got[-1] == pytest.approx(3.0),
                          timeout=30, publish=publish), got[-3:]
        end(pid)
        wait_for(r, "unloaded /ws_pid", 30)
    finally:
        end(r, *(p for p in (pid,) if p is not None))
    assert r.returncode == 0, read_rest(r)
