"""A controller's load request, built in one place for every way it is loaded.

A controller is loaded by name in three ways: a spawner node that ``rtcf launch``
reads (:mod:`._spawner`), ``load_controller`` on a runner's controller manager (under
``rtcf launch`` or ``rt_runner``, from a real spawner or ``ros2 control``). All of them
end in :func:`controller_spec`: the class installed for the type, named NAME in the
controller manager's namespace, its parameters (ROS 2's dotted names made rtcf's
``/`` tree), its failure policy, rate and lane read from them, its remaps.

Its parameters are merged, later ones winning, as ros2_control's controller node gets
them (:func:`controller_params`): the sections matching it in the runner's files, then
in the files the spawner gave (``-p``, or ``<NAME>.params_file`` set on the manager),
then ``--params-file`` of its node options, then their ``-p NAME:=VALUE``.
:func:`node_options` reads node options (``--controller-ros-args``, or
``<NAME>.node_options_args`` set on the manager) as the controller's node reads its
ROS arguments.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import yaml

from .._core._errors import ConfigurationError, Location
from .._core._faults import FailurePolicy
from .._core._lane_names import lane_from_params
from .._core._names import expand
from .._core._rates import Rate
from .._core._runner import ComponentSpec
from ._controller_setup import ControllerSetup, read_setup
from ._controller_types import resolve


@dataclass
class NodeOptions:
    """A controller node's ROS arguments: remaps, ``--params-file`` files (absolute),
    ``-p`` parameters (dotted names, YAML-typed values)."""

    remaps: list[tuple[str, str]] = field(default_factory=list)
    params_files: list[str] = field(default_factory=list)
    params: dict[str, Any] = field(default_factory=dict)

    def add(self, other: NodeOptions) -> None:
        self.remaps += other.remaps
        self.params_files += other.params_files
        self.params.update(other.params)


def node_options(words: Sequence[str]) -> NodeOptions:
    """``[--ros-args] -r FROM:=TO -p NAME:=VALUE --params-file FILE ...``; a
    ConfigurationError names what is not read (a ``__ns``/``__node`` remap, a
    node-specific rule, any other ROS argument) or is malformed."""
    options = NodeOptions()
    i = 0
    while i < len(words):
        word = words[i]
        i += 1
        if word in ("--ros-args", "--"):
            continue
        if word not in ("-r", "--remap", "-p", "--param", "--params-file"):
            raise ConfigurationError(f"{word!r} is not read; rtcf reads -r/--remap FROM:=TO, "
                                     "-p/--param NAME:=VALUE and --params-file FILE")
        if i == len(words):
            raise ConfigurationError(f"{word} needs a value")
        value = words[i]
        i += 1
        if word == "--params-file":
            path = os.path.abspath(value)
            if not os.path.isfile(path):
                raise ConfigurationError(f"--params-file {path!r} does not exist")
            options.params_files.append(path)
            continue
        left, assign, right = value.partition(":=")
        if not assign or not left:
            raise ConfigurationError(f"{word} {value!r} is not NAME:=VALUE")
        if word in ("-p", "--param"):
            options.params[left] = _yaml_value(right)
        elif left.startswith("__") or (":" in left and not left.startswith(("/", "~"))):
            raise ConfigurationError(
                f"the remap {value!r} is not read: the controller is named NAME in its "
                "controller manager's namespace (give -c/-n to the spawner), and "
                "node-specific rules (node:from:=to) are not read")
        else:
            options.remaps.append((left, right))
    return options


def _yaml_value(text: str) -> Any:
    """A ``-p`` value as rcl reads it: YAML (``1`` an int, ``[1.0, 2.0]`` an array)."""
    try:
        return yaml.safe_load(text) if text else ""
    except yaml.YAMLError:
        return text


def controller_params(
    full_name: str, manager: str, setup: ControllerSetup | None, files: Sequence[str],
    options: NodeOptions,
) -> dict[str, Any]:
    """Controller ``full_name``'s parameters (dotted names): the runner's files
    (``setup``), ``files``, its options' files, its options' ``-p``, later winning.
    ``type`` is left in (the caller's type, if it has none of its own)."""
    params: dict[str, Any] = setup.params_for(full_name) if setup is not None else {}
    own = [*files, *options.params_files]
    if own:
        params.update(read_setup(own, manager).params_for(full_name))
    params.update(options.params)
    return params


def controller_spec(
    name: str, namespace: str, type_name: str, params: dict[str, Any], *,
    remaps: Sequence[tuple[str, str]] = (), autostart: bool = True,
    location: Location | None = None, unconfigured: bool = False,
) -> ComponentSpec:
    """The load request of controller ``name`` (in ``namespace``, its controller
    manager's) of ros2_control type ``type_name``; a ConfigurationError when the type is
    not installed or a parameter is refused (``on_error``, ``fallback``, ``update_rate``,
    ``lane``: what the runner reads, checked here). ``unconfigured``: loaded as
    ros2_control's load_controller leaves it (its configure not run)."""
    module, class_name = resolve(type_name)
    # ROS 2 nests parameter names with '.', rtcf's tree with '/'
    tree = {key.replace(".", "/"): value for key, value in params.items() if key != "type"}
    full = expand(name, namespace)
    return ComponentSpec(
        name=name, module=module, class_name=class_name, namespace=namespace, params=tree,
        remaps=list(remaps), location=location, autostart=autostart,
        unconfigured=unconfigured,
        policy=FailurePolicy.from_params(tree, full),  # on_error, fallback
        rate=Rate.from_params(tree, full),  # update_rate, as ros2_control's
        lane=lane_from_params(tree, full),
    )
