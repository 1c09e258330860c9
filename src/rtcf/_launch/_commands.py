"""The programs a launch file runs while it is read: ``$(command ...)``, ``$(find-exec ...)``
and roslaunch's ``<param command=...>``.

As launch's ``Command`` and ``FindExecutable`` substitutions and roslaunch's parameter
loader do it: the command's text is split as a shell would split it (:func:`shlex.split`,
no shell runs), the program is looked up on ``PATH`` and run once, while the file is
read (never in the loop), and its standard output is the value. Beyond them, a program
that is not on ``PATH`` is also looked for where this Python's console scripts are
(a virtual environment's ``bin``, where pip put ``xacro``), so that a venv need not be
activated; and the program's environment gets this Python's prefix on
``AMENT_PREFIX_PATH`` when that prefix holds an ament index (the ROS 2 wheels' and
``scripts/setup-ros2``'s), so that ``xacro``'s ``$(find pkg)`` (ament_index_python's
``get_package_share_directory``) finds the packages rtcf's own ``$(find-pkg-share)``
finds there.

Errors are :class:`CommandFailed` with one line: what went wrong and the first lines
of what the program wrote to stderr; the launch reader adds the file and line.
"""

from __future__ import annotations

import os
import shlex
import shutil
import signal
import subprocess
import sys
import sysconfig
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

ON_STDERR = ("fail", "ignore", "warn", "capture")
TIMEOUT_S = 120.0  # launch waits forever; a launch file that hangs says so here
_SHOWN_LINES = 3
_SHOWN_CHARS = 200


class CommandFailed(Exception):
    """The program could not run or failed; the message is one line."""


@dataclass(frozen=True)
class CommandOutput:
    stdout: str
    stderr: str  # empty when stderr was captured with stdout


def one_line(text: str) -> str:
    """``text`` with its runs of whitespace (newlines too) as single spaces."""
    return " ".join(text.split())


def first_lines(text: str) -> str:
    """The first non-empty lines of a program's stderr, joined into one line."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    shown = [line if len(line) <= _SHOWN_CHARS else line[:_SHOWN_CHARS] + "..."
             for line in lines[:_SHOWN_LINES]]
    more = len(lines) - len(shown)
    return " | ".join(shown) + (f" (and {more} more line{'s' * (more != 1)})" if more else "")


def scripts_directory() -> str:
    """Where this Python's console scripts are installed (a venv's ``bin``)."""
    return sysconfig.get_path("scripts") or os.path.dirname(sys.executable)


def find_executable(name: str) -> str | None:
    """The path of executable ``name``: on ``PATH`` (launch's ``$(find-exec)``), else
    among this Python's console scripts; a name with a ``/`` is taken as a path."""
    found = shutil.which(name)
    if found is None and os.sep not in name:
        found = shutil.which(name, path=scripts_directory())
    return found


def environment(extra: Mapping[str, str] = {}) -> dict[str, str]:
    """The environment a command runs in: this process's, ``extra`` (a launch file's
    ``<set_env>``/``<env>`` in force), and this Python's prefix on ``AMENT_PREFIX_PATH``
    when it holds an ament index and is not there yet."""
    env = dict(os.environ)
    env.update(extra)
    prefixes = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    index = Path(sys.prefix) / "share" / "ament_index" / "resource_index" / "packages"
    known = {os.path.realpath(p) for p in prefixes}
    if index.is_dir() and os.path.realpath(sys.prefix) not in known:
        env["AMENT_PREFIX_PATH"] = os.pathsep.join([*prefixes, sys.prefix])
    return env


def run(command: str, *, capture_stderr: bool = False,
        extra_env: Mapping[str, str] = {}) -> CommandOutput:
    """Run ``command`` (split with shlex, no shell) and return its output.

    ``capture_stderr``: stderr goes into stdout (launch's ``on_stderr='capture'``).
    A program that is not found, cannot start, exits with other than 0, is killed by a
    signal or runs past :data:`TIMEOUT_S` raises :class:`CommandFailed`.
    """
    try:
        argv = shlex.split(command)
    except ValueError as exc:
        raise CommandFailed(f"cannot be split into words: {exc}") from None
    if not argv:
        raise CommandFailed("is empty")
    program = argv[0]
    executable = find_executable(program)
    if executable is None:
        where = "does not exist" if os.sep in program else (
            f"is not on PATH (nor in {scripts_directory()})")
        raise CommandFailed(f"program {program!r} {where}")
    try:
        result = subprocess.run(
            argv, executable=executable, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT if capture_stderr else subprocess.PIPE,
            env=environment(extra_env), encoding="utf-8", errors="replace",
            timeout=TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        raise CommandFailed(f"did not end within {TIMEOUT_S:g} s") from None
    except OSError as exc:
        raise CommandFailed(f"cannot run {executable!r}: {exc.strerror or exc}") from None
    stderr = result.stderr or ""
    if result.returncode != 0:
        if result.returncode < 0:
            try:
                how = f"was killed by {signal.Signals(-result.returncode).name}"
            except ValueError:
                how = f"was killed by signal {-result.returncode}"
        else:
            how = f"exited with code {result.returncode}"
        # captured: its stderr is in its stdout
        label, said = ("output", result.stdout or "") if capture_stderr else ("stderr", stderr)
        shown = first_lines(said)
        raise CommandFailed(how + (f"; {label}: {shown}" if shown else f"; no {label}"))
    return CommandOutput(result.stdout or "", stderr)
