"""``ROSCONSOLE_CONFIG_FILE``: per-component start levels from a log4cxx properties file.

The original's components log through rosconsole, whose log4cxx backend reads, when
a node starts, ``$ROS_ROOT/config/rosconsole.config`` (if it exists) and then the
file that ``ROSCONSOLE_CONFIG_FILE`` names, after it has set the logger ``ros`` to
INFO itself. A component's logger is ``ros.rtcf.<component>``, so a line such as
``log4j.logger.ros.rtcf.arm.sum1=DEBUG`` chooses that component's level at start
(the original's ``logging.launch`` sets the variable with ``<env>``).

This module reads such files the way log4cxx's PropertyConfigurator does, as far as
levels go, and answers the level a component starts at:

* **Names.** For the component ``/arm/sum1`` the loggers that count, most specific
  first, are its own, ``ros.rtcf.arm.sum1`` (rtcf's name, what rqt_logger_level
  shows) or ``ros.rtcf./arm/sum1`` (the original's: ``ros.rtcf.`` and the full name),
  then its namespaces (``ros.rtcf.arm``), then ``ros.rtcf`` and ``ros``. As in
  log4cxx, the nearest one that has a level gives it. If the file sets both
  spellings of the component's own name, the later line wins.
* **Order.** Files are read in rosconsole's order, and within a file a later line
  for the same logger replaces an earlier one (a properties file is a map). The
  runner's default level (``rtcf launch --log-level``, info otherwise) plays the
  part of rosconsole's own ``ros=INFO``: the file's levels go over it.
* **Values.** ``LEVEL`` or ``LEVEL, appender, ...`` (appenders are ignored);
  ``DEBUG``, ``INFO``, ``WARN``, ``ERROR``, ``FATAL`` in any case; ``TRACE`` and
  ``ALL`` count as DEBUG; ``OFF`` as FATAL (rtcf always passes fatal records);
  ``INHERITED`` or ``NULL`` unset the logger's level; an empty level keeps it.
  ``log4j.category.X`` means ``log4j.logger.X``; ``log4j.threshold=LEVEL`` raises
  every level to at least LEVEL. ``${NAME}`` is replaced by the file's own key
  ``NAME`` or else the environment variable. Comments start with ``#`` or ``!``; a
  trailing backslash continues a line. An unknown level is reported and the line
  ignored (log4cxx would take DEBUG). ``log4j.rootLogger`` does not reach
  components: rosconsole sets ``ros`` itself before it reads the file.

No middleware is imported: the embedded default (``rtcf launch``) and the ROS 1
runner (``rt_runner`` under roslaunch) both use it. On ROS 2 the equivalent is
``--ros-args --log-level <logger>:=<level>`` (docs/ros2.md).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from .._core._log import LogLevel

ENV = "ROSCONSOLE_CONFIG_FILE"
ROOT = "ros"
PREFIX = "ros.rtcf"

_LEVELS = {
    "TRACE": LogLevel.DEBUG,
    "ALL": LogLevel.DEBUG,
    "DEBUG": LogLevel.DEBUG,
    "INFO": LogLevel.INFO,
    "WARN": LogLevel.WARNING,
    "WARNING": LogLevel.WARNING,
    "ERROR": LogLevel.ERROR,
    "FATAL": LogLevel.FATAL,
    "OFF": LogLevel.FATAL,
}
_UNSET = ("INHERITED", "NULL")
_LOGGER_KEYS = ("log4j.logger.", "log4j.category.")
_VAR = re.compile(r"\$\{([^}]*)\}")


@dataclass
class RosconsoleConfig:
    """The logger levels that one or more rosconsole config files set."""

    # logger name -> (level, position of the line that set it, across all files)
    levels: dict[str, tuple[int, int]] = field(default_factory=dict)
    threshold: int | None = None
    sources: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    _lines: int = 0

    # -- reading -----------------------------------------------------------------
    def read_text(self, text: str, source: str, environ: Mapping[str, str] | None = None) -> None:
        """Apply one file's lines over what earlier files set."""
        env = os.environ if environ is None else environ
        self.sources.append(source)
        props = _properties(text)
        values = {key: value for key, (value, _) in props.items()}
        for key, (raw, line) in sorted(props.items(), key=lambda kv: kv[1][1]):
            where = f"{source}:{line}"
            value = _substitute(raw, values, env)
            if key == "log4j.threshold":
                level = self._level(value, key, where)
                if level is not None:
                    self.threshold = level
                continue
            name = next((key[len(p):] for p in _LOGGER_KEYS if key.startswith(p)), None)
            if name is None or not name:
                continue  # appenders, additivity, rootLogger: not levels of ros.* loggers
            word = value.split(",", 1)[0].strip()
            if not word:
                continue  # "log4j.logger.x=, A1": appenders only, the level stays
            if word.upper() in _UNSET:
                self.levels.pop(name, None)
                continue
            level = self._level(word, key, where)
            if level is not None:
                self._lines += 1
                self.levels[name] = (level, self._lines)

    def read_file(
        self, path: str | os.PathLike[str], environ: Mapping[str, str] | None = None
    ) -> bool:
        """Read ``path``; a file that cannot be read is a warning, as in rosconsole."""
        try:
            text = Path(path).read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            self.warnings.append(
                f"{ENV}: cannot read {os.fspath(path)!r} ({exc.strerror or exc}); "
                "component log levels stay at the default"
            )
            return False
        self.read_text(text, os.fspath(path), environ)
        return True

    def _level(self, word: str, key: str, where: str) -> int | None:
        level = _LEVELS.get(word.strip().split(",", 1)[0].strip().upper())
        if level is None:
            self.warnings.append(
                f"{where}: {key}: unknown level {word.strip()!r} (use DEBUG, INFO, WARN, "
                "ERROR or FATAL); line ignored"
            )
            return None
        return int(level)

    # -- answering -----------------------------------------------------------------
    def component_level(self, component: str, default: int) -> int:
        """The level ``component`` (its full name, '/arm/sum1') starts at."""
        level = self.set_level(component)
        level = default if level is None else level
        if self.threshold is not None:
            level = max(level, self.threshold)
        return level

    def set_level(self, component: str) -> int | None:
        """The level the files give ``component``, or None if none of its loggers has one."""
        parts = [p for p in component.split("/") if p]
        own = [f"{PREFIX}." + ".".join(parts), f"{PREFIX}./" + "/".join(parts)]
        found = [self.levels[n] for n in own if n in self.levels]
        if found:
            return max(found, key=lambda entry: entry[1])[0]  # the later line
        for n in range(len(parts) - 1, 0, -1):  # the namespaces, innermost first
            entry = self.levels.get(f"{PREFIX}." + ".".join(parts[:n]))
            if entry is not None:
                return entry[0]
        for name in (PREFIX, ROOT):
            entry = self.levels.get(name)
            if entry is not None:
                return entry[0]
        return None

    def describe(self) -> str:
        """One line: which files, and which loggers they set."""
        set_ = ", ".join(
            f"{name}={LogLevel(level).name}" for name, (level, _) in self.levels.items()
        )
        return f"{ENV}: {', '.join(self.sources)}: {set_ or 'no logger levels'}"


def from_environment(environ: Mapping[str, str] | None = None) -> RosconsoleConfig | None:
    """The config rosconsole would read in this environment, or None if it reads none.

    ``$ROS_ROOT/config/rosconsole.config`` first (if it exists), then the file that
    ``ROSCONSOLE_CONFIG_FILE`` names.
    """
    env = os.environ if environ is None else environ
    config = RosconsoleConfig()
    found = False
    root = env.get("ROS_ROOT")
    if root:
        default = Path(root) / "config" / "rosconsole.config"
        if default.is_file():
            found = config.read_file(default, env) or found
    path = env.get(ENV)
    if path:
        config.read_file(path, env)
        found = True  # even unreadable: its warning must be seen
    return config if found else None


def _properties(text: str) -> dict[str, tuple[str, int]]:
    """A Java properties file as {key: (value, line number)}; a later key wins."""
    out: dict[str, tuple[str, int]] = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        number = i + 1
        line = lines[i].lstrip()
        i += 1
        if not line or line[0] in "#!":
            continue
        while _continues(line) and i < len(lines):
            line = line[:-1] + lines[i].lstrip()
            i += 1
        if _continues(line):
            line = line[:-1]
        key, value = _split(line)
        if key:
            out.pop(key, None)  # keep the order of the last occurrence
            out[key] = (value, number)
    return out


def _continues(line: str) -> bool:
    trailing = len(line) - len(line.rstrip("\\"))
    return trailing % 2 == 1


def _split(line: str) -> tuple[str, str]:
    """key and value: the first unescaped '=', ':' or whitespace separates them."""
    key = []
    j = 0
    while j < len(line):
        c = line[j]
        if c == "\\" and j + 1 < len(line):
            key.append(line[j + 1])
            j += 2
            continue
        if c in "=: \t\f":
            break
        key.append(c)
        j += 1
    rest = line[j:].lstrip(" \t\f")
    if rest[:1] in ("=", ":"):
        rest = rest[1:].lstrip(" \t\f")
    return "".join(key), rest.strip()


def _substitute(value: str, props: Mapping[str, str], env: Mapping[str, str]) -> str:
    def one(m: re.Match[str]) -> str:
        name = m.group(1)
        return props.get(name, env.get(name, ""))

    return _VAR.sub(one, value)
