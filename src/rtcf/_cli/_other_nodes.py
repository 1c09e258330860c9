"""A launch file's other nodes, started by ``rtcf launch`` as ``ros2 launch`` would.

A bringup file holds more than the runner, its components and the spawners:
``robot_state_publisher``, a teleop, a dashboard. ``rtcf launch`` starts each such
``<node pkg exec name namespace>`` of a ROS 2 launch file as a child process, as
launch_ros' ``Node`` does:

* the executable is ``<prefix>/lib/<pkg>/<exec>``, ``<prefix>`` the first on
  ``AMENT_PREFIX_PATH`` (then this Python's prefix, where pip installs ROS 2 wheels,
  as rtcf's ``$(find-pkg-share)`` looks) whose ament index registers the package
  (``share/ament_index/resource_index/packages/<pkg>``): ament_index_python's
  ``get_package_prefix``, and so ``ros2 run``'s look-up;
* its command line is ``exec ARGS [--ros-args ROS_ARGS] --ros-args -r __node:=NAME
  -r __ns:=NS [--params-file FROM]... [--params-file TMP] [-r FROM:=TO]...``:
  ``args`` first, then ``ros_args``, then what launch_ros adds in its order; ``TMP``
  is a temporary parameters file (``/**: ros__parameters:``, as launch_ros writes
  one) with the node's parameters as the launch file left them (its ``<param>``\\ s
  and the sections of its ``<param from=...>`` files, later ones winning);
* its environment is rtcf's with the file's ``<env>``/``<set_env>`` and
  ``PYTHONUNBUFFERED=1``;
* its output (``output``, default ``log``, as launch's): ``screen``, ``both`` and
  ``full`` put stdout and stderr on the terminal, each line prefixed
  ``[<exec>-<N>]`` as ros2 launch prefixes it (N counts the processes started);
  ``log`` puts stderr there (where ROS 2's loggers write) and stdout in the log
  file; ``own_log`` both in the log file. The log file is ``launch.log`` in a
  directory of its own under ``$ROS_LOG_DIR`` (else ``$ROS_HOME/log``, else
  ``~/.ros/log``), as ros2 launch's.

A node that ends while the loop runs is reported in one line with its exit code; the
loop goes on, unless the node has ``on_exit="shutdown"`` (ROS 2) or
``required="true"`` (ROS 1): then the loop stops, as launch shuts down. When the loop
ends (or ``rtcf launch`` is interrupted) every node still running gets SIGINT
(unless the terminal's Ctrl-C reached it already), SIGTERM 5 s later and SIGKILL 5 s
after that, launch's ``sigterm_timeout`` and ``sigkill_timeout``; each one's exit is
reported.

A node whose package is not installed, or whose package has no such executable, is
one line naming the file, the line, the package and what to do; the run goes on.
ROS 1 nodes (``type=``) are not started: under ROS 1, ``roslaunch`` runs the file and
starts them.

This module is in the command line's layer, not the runtime's: it reads the launch
description (``_launch``), which ``_runtime`` may not import, and only ``rtcf
launch`` starts other nodes (under ``ros2 launch`` or ``roslaunch``, the launcher
does). Nothing here runs in the worker: the children are the supervisor's, and its
threads read their output.
"""

from __future__ import annotations

import datetime
import os
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import yaml

from .._core._params import ParameterStore
from .._launch._description import NodeDescription

SIGTERM_TIMEOUT = 5.0  # launch's sigterm_timeout: SIGINT, then this long, then SIGTERM
SIGKILL_TIMEOUT = 5.0  # launch's sigkill_timeout: SIGTERM, then this long, then SIGKILL
_SCREEN = ("screen", "both", "full")


class NotInstalled(Exception):
    """The node's package or executable is not where ros2 run would find it."""


def package_prefix(package: str, environ: Mapping[str, str] | None = None) -> str | None:
    """The install prefix whose ament index registers ``package`` (or None)."""
    env = os.environ if environ is None else environ
    prefixes = [*filter(None, env.get("AMENT_PREFIX_PATH", "").split(os.pathsep)), sys.prefix]
    for prefix in prefixes:
        marker = Path(prefix, "share", "ament_index", "resource_index", "packages", package)
        if marker.is_file():
            return prefix
    return None


def find_executable(package: str, executable: str,
                    environ: Mapping[str, str] | None = None) -> str:
    """``<prefix>/lib/<package>/<executable>``, as ``ros2 run`` and launch_ros find it."""
    env = os.environ if environ is None else environ
    prefix = package_prefix(package, env)
    if prefix is None:
        searched = ", ".join([*filter(None, env.get("AMENT_PREFIX_PATH", "").split(os.pathsep)),
                              sys.prefix])
        raise NotInstalled(
            f"package {package!r} is not installed (no ament index of {searched} registers "
            f"it); install it (ros-jazzy-{package.replace('_', '-')}, or build it into a "
            "prefix) and source its setup file so that AMENT_PREFIX_PATH holds its prefix, "
            "or remove the node")
    libexec = Path(prefix, "lib", package)
    path = libexec / executable
    if path.is_file() and os.access(path, os.X_OK):
        return str(path)
    found = sorted(p.name for p in libexec.iterdir()
                   if p.is_file() and os.access(p, os.X_OK)) if libexec.is_dir() else []
    raise NotInstalled(
        f"package {package!r} ({prefix}) has no executable {executable!r} in {libexec} "
        f"(it has: {', '.join(found) or 'none'}); correct exec=, or reinstall the package")


def resolve(node: NodeDescription, environ: Mapping[str, str]) -> tuple[str | None, str]:
    """The node's executable, or None and the one line that says why it is not started."""
    where = f"{node.location}: node {node.full_name}"
    if node.dialect == "ros1":
        return None, (f"note: {where} ({node.package}/{node.executable}) not started: "
                      "rtcf launch starts the nodes of ROS 2 launch files; under ROS 1, "
                      "roslaunch runs this file and starts it")
    try:
        return find_executable(node.package, node.executable, environ), ""
    except NotInstalled as exc:
        return None, f"warning: {where} not started: {exc}"


def check_lines(nodes: Sequence[NodeDescription],
                environ: Mapping[str, str] | None = None) -> list[str]:
    """What ``rtcf check`` says of the other nodes: what rtcf launch would start, or why not."""
    env = os.environ if environ is None else environ
    lines = []
    for node in nodes:
        executable, problem = resolve(node, env)
        lines.append(problem or f"note: {node.location}: node {node.full_name}: rtcf launch "
                                f"starts {executable}")
    return lines


def command(node: NodeDescription, executable: str, params_file: str | None) -> list[str]:
    """The node's command line, in launch_ros' order."""
    argv = [executable, *shlex.split(node.args)]  # args, then --ros-args ROS_ARGS
    argv += ["--ros-args", "-r", f"__node:={node.name}", "-r", f"__ns:={node.namespace}"]
    for path in node.params_files:
        argv += ["--params-file", path]
    if params_file is not None:
        argv += ["--params-file", params_file]
    for source, target in node.remaps:
        argv += ["-r", f"{source}:={target}"]
    return argv


def write_params_file(values: Mapping[str, Any]) -> str:
    """A temporary parameters file for every node (``/**``), as launch_ros writes one."""
    with tempfile.NamedTemporaryFile("w", prefix="launch_params_", suffix=".yaml",
                                     delete=False) as handle:
        yaml.safe_dump({"/**": {"ros__parameters": dict(values)}}, handle)
    return handle.name


def _log_dir(environ: Mapping[str, str]) -> Path:
    if environ.get("ROS_LOG_DIR"):
        return Path(environ["ROS_LOG_DIR"])
    if environ.get("ROS_HOME"):
        return Path(environ["ROS_HOME"], "log")
    return Path.home() / ".ros" / "log"


def _exit_text(code: int) -> str:
    if code < 0:
        try:
            return f"was ended by {signal.Signals(-code).name} (exit code {code})"
        except ValueError:
            pass
    return f"exited with code {code}"


@dataclass
class _Child:
    node: NodeDescription
    label: str  # [<exec>-<N>], as ros2 launch prefixes the node's lines
    process: subprocess.Popen[bytes]
    argv: list[str]
    threads: list[threading.Thread] = field(default_factory=list)
    reported: bool = False  # its exit is reported already
    signals: list[str] = field(default_factory=list)  # what stop() sent it


class OtherNodes:
    """Starts, watches and stops a launch file's other nodes (see the module's text).

    ``say`` prints one of rtcf's lines (``rtcf: ...``); ``write(text, is_stderr)``
    prints a node's prefixed line; ``on_shutdown`` is called (from a watching thread)
    when a node with ``on_exit="shutdown"`` ends while the loop runs.
    """

    def __init__(
        self,
        nodes: Sequence[NodeDescription],
        parameters: ParameterStore,
        *,
        say: Callable[[str], None],
        write: Callable[[str, bool], None] | None = None,
        on_shutdown: Callable[[], None] | None = None,
        environ: Mapping[str, str] | None = None,
        timeouts: tuple[float, float] = (SIGTERM_TIMEOUT, SIGKILL_TIMEOUT),
    ) -> None:
        self._nodes = list(nodes)
        self._parameters = parameters
        self._say = say
        self._write = write or _write
        self._on_shutdown = on_shutdown
        self._environ = dict(os.environ if environ is None else environ)
        self._timeouts = timeouts
        self._lock = threading.Lock()
        self._children: list[_Child] = []
        self._temp_files: list[str] = []
        self._stopping = False
        self._sigint_delivered = False
        self._log: IO[str] | None = None
        self._log_path = _log_dir(self._environ) / (
            f"{datetime.datetime.now():%Y-%m-%d-%H-%M-%S-%f}-{socket.gethostname()}-{os.getpid()}")
        self.shutdown_by: str | None = None  # the node whose exit ended the launch

    @property
    def pids(self) -> dict[str, int]:
        """The running children's pids by node name."""
        return {c.node.full_name: c.process.pid for c in self._children}

    def start(self) -> None:
        """Start every node that can be started; say why for each one that cannot."""
        for node in self._nodes:
            executable, problem = resolve(node, self._environ)
            if executable is None:
                self._say(problem)
            else:
                self._start(node, executable)
        if any((c.node.output or "log") not in _SCREEN for c in self._children):
            self._say(f"the stdout of nodes without output=\"screen\" goes to "
                      f"{self._log_path / 'launch.log'}, as ros2 launch logs it")

    def _start(self, node: NodeDescription, executable: str) -> None:
        private = self._parameters.get(node.full_name, {})
        params_file = None
        if isinstance(private, dict) and private:
            params_file = write_params_file(private)
            self._temp_files.append(params_file)
        argv = command(node, executable, params_file)
        env = {**self._environ, **node.env}
        env.setdefault("PYTHONUNBUFFERED", "1")
        label = f"{node.executable}-{len(self._children) + 1}"
        try:
            process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, env=env)
        except OSError as exc:
            self._say(f"warning: {node.location}: node {node.full_name} not started: "
                      f"{executable}: {exc.strerror or exc}")
            return
        child = _Child(node, label, process, argv)
        self._children.append(child)
        self._say(f"node {node.full_name}: started {node.package}/{node.executable} "
                  f"[{label}], pid {process.pid}")
        output = node.output or "log"
        assert process.stdout is not None and process.stderr is not None
        for pipe, is_err in ((process.stdout, False), (process.stderr, True)):
            screen = output in _SCREEN or (is_err and output == "log")
            child.threads.append(threading.Thread(
                target=self._pump, args=(child, pipe, is_err, screen), daemon=True,
                name=f"rtcf-{label}-{'err' if is_err else 'out'}"))
        child.threads.append(threading.Thread(target=self._watch, args=(child,), daemon=True,
                                              name=f"rtcf-{label}-wait"))
        for thread in child.threads:
            thread.start()

    def _pump(self, child: _Child, pipe: IO[bytes], is_err: bool, screen: bool) -> None:
        for raw in iter(pipe.readline, b""):
            line = f"[{child.label}] {raw.decode(errors='replace').rstrip()}"
            with self._lock:
                if screen:
                    self._write(line, is_err)
                else:
                    self._log_line(line)
        pipe.close()

    def _log_line(self, line: str) -> None:
        if self._log is None:
            try:
                self._log_path.mkdir(parents=True, exist_ok=True)
                self._log = open(self._log_path / "launch.log", "a", encoding="utf-8")
            except OSError:
                return
        self._log.write(line + "\n")
        self._log.flush()

    def _watch(self, child: _Child) -> None:
        code = child.process.wait()
        with self._lock:
            if self._stopping:
                return
            child.reported = True
            node = child.node
            shutdown = node.on_exit == "shutdown"
            text = (f"{node.location}: node {node.full_name} ({node.package}/{node.executable}, "
                    f"pid {child.process.pid}) {_exit_text(code)}")
            if code != 0:
                text += f", cmd '{shlex.join(child.argv)}'"
            if shutdown:
                self.shutdown_by = node.full_name
                text += ("; it is required (on_exit=\"shutdown\" / required=\"true\"): "
                         "stopping the loop")
            else:
                text += "; the loop goes on"
            self._say(text)
        if shutdown and self._on_shutdown is not None:
            self._on_shutdown()

    def note_signal(self, signum: int) -> None:
        """rtcf launch got ``signum``: a Ctrl-C on the terminal reached the nodes too
        (one process group), so stop() sends them no SIGINT of its own, as launch."""
        if signum == signal.SIGINT and _terminal_foreground():
            self._sigint_delivered = True

    def stop(self) -> None:
        """SIGINT, SIGTERM, SIGKILL, as launch's timeouts say; report each exit."""
        with self._lock:
            if self._stopping:
                return
            self._stopping = True
        running = [c for c in self._children if c.process.poll() is None]
        steps = [(signal.SIGINT, self._timeouts[0]), (signal.SIGTERM, self._timeouts[1]),
                 (signal.SIGKILL, None)]
        for index, (sig, timeout) in enumerate(steps):
            running = [c for c in running if c.process.poll() is None]
            if not running:
                break
            if not (index == 0 and self._sigint_delivered):
                for child in running:
                    _signal(child, sig)
            deadline = None if timeout is None else time.monotonic() + timeout
            for child in running:
                try:
                    child.process.wait(None if deadline is None
                                       else max(0.0, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    pass
        for child in self._children:
            for thread in child.threads:
                thread.join(timeout=2.0)
        for child in self._children:
            if not child.reported:
                code = child.process.poll()
                how = (f"stopped (sent {', '.join(child.signals)})" if child.signals
                       else "stopped by the terminal's Ctrl-C")
                self._say(f"node {child.node.full_name}: {how}, "
                          f"{_exit_text(code if code is not None else 0)}")
        for path in self._temp_files:
            try:
                os.unlink(path)
            except OSError:
                pass
        if self._log is not None:
            self._log.close()


def _signal(child: _Child, sig: signal.Signals) -> None:
    try:
        child.process.send_signal(sig)
    except ProcessLookupError:
        return
    child.signals.append(sig.name)


def _terminal_foreground() -> bool:
    """Whether this process is in its terminal's foreground process group (a Ctrl-C
    there goes to every process of the group, the children included)."""
    try:
        return os.tcgetpgrp(sys.stdin.fileno()) == os.getpgrp()
    except (OSError, ValueError, AttributeError):
        return False


_WRITE_LOCK = threading.Lock()


def _write(text: str, is_stderr: bool) -> None:
    stream = sys.stderr if is_stderr else sys.stdout
    with _WRITE_LOCK:
        print(text, file=stream, flush=True)
