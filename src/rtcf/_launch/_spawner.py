"""ros2_control's ``spawner`` nodes in a launch file, read as the components they load.

A ros2_control bringup starts ``<node pkg="controller_manager" exec="spawner"
args="NAME... [--inactive] [-p FILE] [-c MANAGER]"/>`` once per controller (or per
group). Under ``rtcf launch`` no spawner process runs: each NAME becomes a component
of the runner whose controller manager the spawner names, as the spawner's services
calls would make it: the class installed for NAME's type (:mod:`._controller_types`),
named NAME in the controller manager's namespace, configured with its section's
``ros__parameters`` (the runner's files, then ``-p`` files, later winning), and
active from the start unless ``--inactive`` (then configured and left inactive) or
``--load-only`` (then loaded unconfigured: its configure not run).
``--controller-ros-args`` (remaps ``-r``, parameters ``-p``, ``--params-file``) are
the controller node's own, as the controller manager gives them to it: the
component's remaps, and parameters that override its sections'.

:func:`parse` reads a spawner's ``args`` as Jazzy's spawner (and Humble's ``-t``)
does; :func:`controller_specs` turns them into :class:`ComponentSpec`\\ s.
"""

from __future__ import annotations

import os
import shlex
from dataclasses import dataclass, field

from .._core._errors import ConfigurationError, LaunchError
from .._core._names import expand, namespace_of
from .._core._runner import ComponentSpec
from ._controller_setup import ControllerSetup
from ._controller_specs import NodeOptions, controller_params, controller_spec, node_options
from ._description import NodeDescription

PACKAGE = "controller_manager"
SPAWNER = "spawner"

# Options that change only how the spawner talks to the controller manager (waiting,
# switching, cleaning up when killed): the runner loads and starts everything at once
# and unloads it when it stops, so they are ignored, with a warning.
_IGNORED_WITH_VALUE = ("--controller-manager-timeout", "--switch-timeout",
                       "--service-call-timeout")
# the options with a value that rtcf reads, by what they set
_KEYS = {"-c": "c", "--controller-manager": "c", "-p": "p", "--param-file": "p",
         "-n": "n", "--namespace": "n", "-t": "t", "--controller-type": "t",
         "--controller-ros-args": "ros_args"}
_WITH_VALUE = (*_KEYS, *_IGNORED_WITH_VALUE)
_IGNORED_FLAGS = ("-u", "--unload-on-kill", "--switch-asap", "--no-switch-asap")
# what --activate-as-group asks for is what rtcf does anyway: every controller of the
# file starts in the loop's first iteration, together
_SERVED_FLAGS = ("--inactive", "--activate-as-group", "--load-only")
# Options rtcf cannot honour: an error, with what to do instead.
_REFUSED = {
    "--controller": "the advanced per-controller form is not read; use one spawner node "
                    "per set of options",
    "--ros-args": "give the spawner's ROS arguments as <remap>/<param> of the runner",
    "-h": "nothing to show here", "--help": "nothing to show here",
}


def is_spawner(node: NodeDescription) -> bool:
    return node.package == PACKAGE and node.executable == SPAWNER


def node_name(executable: str, args: str) -> str | None:
    """The name ros2_control's node gives itself when the launch file gives none:
    ``controller_manager`` (ros2_control_node), ``spawner_<first NAME>`` (spawner)."""
    if executable == "ros2_control_node":
        return "controller_manager"
    return default_name(args) if executable == SPAWNER else None


def default_name(args: str) -> str:
    """A spawner node's name when the launch file gives none: ``spawner_<first NAME>``."""
    try:
        words = shlex.split(args)
    except ValueError:
        return SPAWNER
    first = next((w for i, w in enumerate(words)
                  if not w.startswith("-") and (i == 0 or words[i - 1] not in _WITH_VALUE)), "")
    return f"{SPAWNER}_{first}" if first.replace("_", "").isalnum() else SPAWNER


@dataclass
class SpawnRequest:
    """What one spawner node asks for."""

    names: list[str]
    manager: str  # the controller manager's full name
    param_files: list[str] = field(default_factory=list)
    inactive: bool = False
    load_only: bool = False  # loaded unconfigured (ComponentSpec.unconfigured)
    type_name: str = ""  # -t/--controller-type (Humble): the type of every NAME
    ignored: list[str] = field(default_factory=list)  # options that change nothing here
    # --controller-ros-args, for every NAME: its node's remaps, --params-file files and
    # -p parameters (dotted names, YAML-typed values)
    options: NodeOptions = field(default_factory=NodeOptions)


def _error(node: NodeDescription, message: str) -> LaunchError:
    return LaunchError(f"spawner {node.full_name!r}: {message}",
                       file=node.location.file, line=node.location.line)


def parse(node: NodeDescription) -> SpawnRequest:
    """The spawner's ``args``; an option rtcf cannot honour or does not know is an
    error naming it."""
    try:
        words = shlex.split(node.args)
    except ValueError as exc:
        raise _error(node, f"args {node.args!r} cannot be split: {exc}") from None
    names: list[str] = []
    values: dict[str, list[str]] = {}
    flags: set[str] = set()
    ignored: list[str] = []
    i = 0
    while i < len(words):
        word = words[i]
        option, eq, inline = word.partition("=")
        i += 1
        if not word.startswith("-"):
            names.append(word)
        elif option in _REFUSED:
            raise _error(node, f"option {option} is not supported by rtcf: {_REFUSED[option]}")
        elif option in _WITH_VALUE:
            if not eq:
                if i == len(words):
                    raise _error(node, f"option {option} needs a value")
                inline, i = words[i], i + 1
            if option in _IGNORED_WITH_VALUE:
                ignored.append(option)
            else:
                values.setdefault(_KEYS[option], []).append(inline)
        elif word in _IGNORED_FLAGS:
            ignored.append(word)
        elif word in _SERVED_FLAGS:
            flags.add(word)
        else:
            raise _error(node, f"unknown option {word!r} in args; rtcf reads NAME..., "
                               "--inactive, --load-only, --activate-as-group, -p/--param-file, "
                               "-c/--controller-manager, -n/--namespace, "
                               "-t/--controller-type and --controller-ros-args")
    if not names:
        raise _error(node, "args names no controller; give args=\"NAME [NAME...]\"")
    namespace = node.namespace
    if "n" in values:
        namespace = expand(values["n"][-1], "/")
    manager = expand(values.get("c", ["controller_manager"])[-1], namespace)
    files = [os.path.abspath(p) for p in values.get("p", [])]
    for path in files:
        if not os.path.isfile(path):
            raise _error(node, f"-p/--param-file {path!r} does not exist")
    request = SpawnRequest(names, manager, files, "--inactive" in flags,
                           "--load-only" in flags, values.get("t", [""])[-1], ignored)
    for text in values.get("ros_args", []):  # repeated: each adds to the others
        _controller_ros_args(node, text, request)
    return request


def _controller_ros_args(node: NodeDescription, text: str, request: SpawnRequest) -> None:
    """One ``--controller-ros-args`` value, as the controller's node reads its ROS
    arguments (``[--ros-args] -r FROM:=TO -p NAME:=VALUE --params-file FILE``)."""
    try:
        request.options.add(node_options(shlex.split(text)))
    except ValueError as exc:
        raise _error(node, f"--controller-ros-args {text!r}: cannot be split: {exc}") from None
    except ConfigurationError as exc:
        raise _error(node, f"--controller-ros-args {text!r}: {exc.message}") from None


def controller_specs(node: NodeDescription, request: SpawnRequest,
                     setup: ControllerSetup | None) -> list[ComponentSpec]:
    """One component per NAME, loaded as the controller manager ``setup`` would load
    it (``setup`` None: the runner was given no parameters file)."""
    namespace = namespace_of(request.manager)
    specs: list[ComponentSpec] = []
    for name in request.names:
        full = expand(name, namespace)
        params = controller_params(full, request.manager, setup, request.param_files,
                                   request.options)
        # -t, else a type in NAME's section of the spawner's own files, else the
        # controller manager's NAME.type
        own = controller_params(full, request.manager, None, request.param_files,
                                request.options)
        type_name = request.type_name or str(own.get("type") or "") or (
            setup.types.get(name, "") if setup is not None else "")
        if not type_name:
            files = ", ".join(setup.files) if setup is not None else "none"
            raise _error(node, f"controller {name!r} has no type: the controller manager "
                               f"{request.manager}'s section (in the runner's parameters "
                               f"files: {files}) has no '{name}.type'; add it there, as "
                               f"'{name}: {{type: PACKAGE/Class}}' under ros__parameters")
        try:
            specs.append(controller_spec(
                name, namespace, type_name, params, remaps=request.options.remaps,
                autostart=not (request.inactive or request.load_only), location=node.location,
                unconfigured=request.load_only))
        except ConfigurationError as exc:
            raise _error(node, f"controller {name!r}: {exc.message}") from None
    return specs
