"""Starting rtcf's ROS 1 executables and roslaunch as the ROS 1 tests' child processes."""

import os
import signal
import subprocess
import sys
from pathlib import Path

from .._proc import read_rest
from .conftest import PORT, rtcf_env

ROOT = Path(__file__).resolve().parents[2]
ROS1 = ROOT / "ros1"
BIN = ROS1 / "rtcf"  # the executables roslaunch finds for pkg="rtcf"


def ros1_env():
    """What docs/ros1.md's one-time setup gives: the packages on ROS_PACKAGE_PATH and
    .venv-ros1's bin first on PATH."""
    env = rtcf_env()
    env["ROS_PACKAGE_PATH"] = os.pathsep.join([str(ROS1), str(ROOT / "src")])
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONUNBUFFERED"] = "1"
    return env


def start(*cmd):
    return subprocess.Popen(
        [str(c) for c in cmd],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=ros1_env(),
        start_new_session=True,  # a Ctrl-C of pytest does not reach it half-way
    )


def rt_runner(name, **params):
    """rt_runner __name:=NAME, with private parameters as _param:=value arguments."""
    params.setdefault("mode", "no_wait")
    params.setdefault("frequency", 100.0)
    args = [f"__name:={name}"] + [f"_{k}:={v}" for k, v in params.items()]
    return start(BIN / "rt_runner", *args)


def rt_launcher(runner, name, cls, *remaps, package="rtcf_examples", first=False):
    args = [package, cls, f"__name:={name}", f"_runner:={runner}", *remaps]
    return start(BIN / "rt_launcher", *args, *(["-f"] if first else []))


def roslaunch(package, file, *args):
    return start("roslaunch", "--screen", "-p", PORT, package, file, *args)


def rtcf_launch(package, file, *args):
    """The same launch file without roslaunch: rtcf launch --middleware ros1."""
    return start(sys.executable, "-m", "rtcf", "launch", package, file, "--middleware", "ros1",
                 *args)


def end(*procs, sig=signal.SIGINT):
    """Stop (SIGINT, as Ctrl-C would) and reap; returns each one's stderr."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(sig)
    outs = []
    for p in procs:
        try:
            _, err = read_rest(p, timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)  # its own session: roslaunch's nodes too
            p.wait()
            err = "(killed)"
        outs.append(err)
    return outs
