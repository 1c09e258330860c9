"""A component's face in a ROS 1 graph: its dynamic_reconfigure server and its logger.

The ROS 1 counterpart of :mod:`rtcf._ros2._face`. rospy allows one node per process,
so a component cannot be a node of its own; what tools need of it lives in the
runner's node (the supervisor), under the component's name:

* **Tunable parameters** (``self.params.declare``) are served by a real
  ``dynamic_reconfigure`` server per component: ``<component>/set_parameters``,
  ``<component>/parameter_descriptions`` and ``<component>/parameter_updates``, as a
  node with a ``.cfg`` would have them. The description is built at run time from the
  declarations (int, double, bool and str; ``choices`` as an enum edit method; ``min``
  and ``max`` as the range), so ``dynparam``, ``dynamic_reconfigure.client`` and
  rqt_reconfigure work. dynamic_reconfigure clamps a value to its range before the
  callback sees it (as the original's C++ server did); the callback then validates
  (a value outside ``choices``, a string too long) and hands the change to the
  worker, which applies it between two iterations. A refused value keeps the old
  one, which the reply and ``parameter_updates`` show, and a warning says why.
* **Logger level**: a Python logger ``ros.rtcf.<component>`` (the original's
  rosconsole name) in the runner's process. rospy's own ``~get_loggers`` and
  ``~set_logger_level`` services (what rqt_logger_level calls) list the process's
  Python loggers and set their levels; a level set on this logger also reaches the
  worker, so filtered records never take room in the log ring.
"""

from __future__ import annotations

import logging
import threading
import types
from collections.abc import Callable
from typing import Any

from .._core._errors import RtcfError
from .._core._log import LogLevel
from .._core._tunables import TunableSpec, Tuner

_INT32 = (-(2**31), 2**31 - 1)  # dynamic_reconfigure/IntParameter holds an int32
_KINDS = {"int": "int", "float": "double", "bool": "bool", "str": "str"}
_CTYPES = {
    "int": ("int", "const int"),
    "double": ("double", "const double"),
    "bool": ("bool", "const bool"),
    "str": ("std::string", "const char * const"),
}
_ALL_LEVELS = 1  # the reconfigure level of every parameter: a change is a change


def rosconsole_logger_name(component: str) -> str:
    """The original's rosconsole logger name of a component: '/rtcf/sum1' -> 'ros.rtcf.sum1'."""
    return "ros.rtcf." + ".".join(p for p in component.split("/") if p)


def level_number(level: int | str | None, default: int = LogLevel.INFO) -> int:
    """An rtcf level (10 ... 50) from a number or a name ('info', 'warn', 'warning')."""
    if level is None or level == "":
        return default
    if isinstance(level, int):
        return int(level)
    name = level.upper()
    name = {"WARN": "WARNING", "CRITICAL": "FATAL"}.get(name, name)
    try:
        return int(LogLevel[name])
    except KeyError:
        return default


class ComponentLogger(logging.Logger):
    """A Python logger whose level changes also reach the component in the worker."""

    rtcf_on_level: Callable[[int], None] | None = None

    def setLevel(self, level: int | str) -> None:
        super().setLevel(level)
        hook = self.rtcf_on_level
        if hook is not None:
            hook(self.level)


def level_of(text: str) -> int:
    """An rtcf level from what ``~set_logger_level`` carries ('warn', 'WARNING', '30');
    unknown names raise :class:`RtcfError`."""
    word = str(text).strip()
    if word.isdigit():
        return int(word)
    number = level_number(word, default=-1)
    if number < 0:
        raise RtcfError(f"unknown log level {text!r} (debug, info, warn, error or fatal)")
    return number


def mirror_level(component: str, level: int) -> None:
    """Show a level set elsewhere on this process's ``ros.rtcf.<component>`` logger,
    without passing it on again (its hook is not called)."""
    logger = logging.getLogger(rosconsole_logger_name(component))
    logging.Logger.setLevel(logger, int(level))
    if isinstance(logger, ComponentLogger):
        face = getattr(logger.rtcf_on_level, "__self__", None)
        if isinstance(face, ComponentFace):
            face.level = int(level)


def component_logger(component: str, level: int, on_level: Callable[[int], None]) -> logging.Logger:
    """The logger ``ros.rtcf.<component>`` at ``level``; ``on_level`` hears later changes."""
    logger = logging.getLogger(rosconsole_logger_name(component))
    if not isinstance(logger, ComponentLogger):
        logger.__class__ = ComponentLogger  # the same object: no other logger is affected
    assert isinstance(logger, ComponentLogger)
    logger.rtcf_on_level = None
    logger.setLevel(level)
    logger.rtcf_on_level = on_level
    return logger


def config_type(specs: list[TunableSpec]) -> Any:
    """What a dynamic_reconfigure ``XConfig`` module generated from a .cfg holds."""
    params = []
    for spec in specs:
        kind = _KINDS[spec.type]
        default = spec.default
        lo: Any
        hi: Any
        if kind == "double":
            default = float(default)
            lo = float(spec.min) if spec.min is not None else -float("inf")
            hi = float(spec.max) if spec.max is not None else float("inf")
        elif kind == "int":
            lo = int(spec.min) if spec.min is not None else _INT32[0]
            hi = int(spec.max) if spec.max is not None else _INT32[1]
            lo, hi = max(lo, _INT32[0]), min(hi, _INT32[1])
        elif kind == "bool":
            lo, hi = False, True
        else:
            lo = hi = ""
        edit_method = ""
        if spec.choices is not None:
            ctype, cconst = _CTYPES[kind]
            edit_method = repr({
                "enum": [
                    {
                        "name": str(c), "type": kind, "value": c, "description": "",
                        "srcline": 0, "srcfile": "", "ctype": ctype, "cconsttype": cconst,
                    }
                    for c in spec.choices
                ],
                "enum_description": spec.description,
            })
        ctype, cconst = _CTYPES[kind]
        params.append({
            "name": spec.name, "type": kind, "default": default, "level": _ALL_LEVELS,
            "description": spec.description, "min": lo, "max": hi, "srcline": 0,
            "srcfile": "", "edit_method": edit_method, "ctype": ctype, "cconsttype": cconst,
        })
    description = {
        "name": "Default", "type": "", "state": True, "cstate": "true", "id": 0, "parent": 0,
        "parameters": params, "groups": [], "srcline": 0, "srcfile": "", "class": "DEFAULT",
        "parentclass": "", "parentname": "Default", "field": "default", "upper": "DEFAULT",
        "lower": "groups",
    }
    return types.SimpleNamespace(
        config_description=description,
        defaults={p["name"]: p["default"] for p in params},
        min={p["name"]: p["min"] for p in params},
        max={p["name"]: p["max"] for p in params},
        level={p["name"]: p["level"] for p in params},
        type={p["name"]: p["type"] for p in params},
        all_level=_ALL_LEVELS,
    )


class ComponentFace:
    """A component's dynamic_reconfigure server and logger, in the runner's rospy node."""

    def __init__(
        self,
        info: dict[str, Any],
        tuner: Tuner,
        default_level: int,
        warn: Callable[[str], None],
    ) -> None:
        self.name = str(info["name"])
        self.tuner = tuner
        self.warn = warn
        self._lock = threading.Lock()
        self.specs = {
            t["name"]: TunableSpec.from_dict({k: v for k, v in t.items() if k != "value"})
            for t in info.get("tunables", [])
        }
        self.values: dict[str, Any] = {t["name"]: t["value"] for t in info.get("tunables", [])}
        self.level = level_number(info.get("log_level"), default_level)
        self.logger = component_logger(self.name, self.level, self._on_level)
        self.server: Any = None
        if self.specs:
            import rospy
            from dynamic_reconfigure.server import Server

            # the server starts from what the parameter server holds: the current values
            for name, value in self.values.items():
                rospy.set_param(f"{self.name}/{name}", value)
            self.server = Server(
                config_type(list(self.specs.values())), self._on_reconfigure, namespace=self.name
            )

    # -- dynamic_reconfigure (rospy's service thread) ----------------------------------
    def _on_reconfigure(self, config: Any, level: int) -> Any:
        with self._lock:
            for name, spec in self.specs.items():
                if name not in config:
                    continue
                old = self.values[name]
                new = config[name]
                if type(new) is type(old) and new == old:
                    continue
                try:
                    value = spec.validate(new)
                    value = self.tuner.set_parameter(self.name, name, value)
                except RtcfError as exc:
                    self.warn(f"dynamic_reconfigure of {self.name}: {exc}; keeping {old!r}")
                    config[name] = old
                    continue
                self.values[name] = value
                config[name] = value
        return config

    # -- logger level (rospy's ~set_logger_level, in its service thread) -------------
    def _on_level(self, level: int) -> None:
        level = max(int(LogLevel.DEBUG), min(int(level), int(LogLevel.FATAL)))
        try:
            self.tuner.set_log_level(self.name, level)
        except RtcfError as exc:
            self.warn(f"logger level of {self.name}: {exc}")
            return
        self.level = level

    def close(self) -> None:
        if isinstance(self.logger, ComponentLogger):
            self.logger.rtcf_on_level = None
        server, self.server = self.server, None
        if server is not None:
            server.set_service.shutdown()
            server.descr_topic.unregister()
            server.update_topic.unregister()
