"""The controller manager's own parameters, as the Jazzy spawner sets them.

Before ``load_controller``, ros2_control's spawner (Jazzy) calls
``<controller_manager>/set_parameters`` with ``<NAME>.node_options_args`` (its
``--controller-ros-args``, a string array), ``<NAME>.params_file`` (its ``-p`` files
that have a section for NAME, a string array) and ``<NAME>.type`` (the type in that
section), and the manager reads them when it loads NAME. ros2_control's manager node
allows undeclared parameters for this; so does rtcf's:

* when the runner's node is the controller manager (``ros2_control_node`` read as a
  runner, or a runner named as its ``controller_manager`` setting), that node takes
  undeclared parameters, as ros2_control's does;
* otherwise a node named as the controller manager is made beside the runner's, in its
  executor, that takes any parameter: ``ros2 param set /controller_manager
  NAME.type ...`` and the spawner reach it, and ``ros2 node list`` shows it.

:meth:`ManagerParameters.controller` gives what was set for one controller. A value
given as a string (``"['a.yaml']"``, as ``ros2 param set`` may leave it) is read as
YAML, as the spawner's own ``get_parameter_value`` reads it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import yaml

from .._core._errors import ConfigurationError
from .._core._names import basename, namespace_of


@dataclass
class SetOnManager:
    """What was set on the manager for one controller (empty: nothing)."""

    type_name: str = ""
    params_files: list[str] = field(default_factory=list)
    node_options_args: list[str] = field(default_factory=list)


class ManagerParameters:
    """The parameters of controller manager ``manager`` (a full name)."""

    def __init__(self, node: Any, manager: str, executor: Any = None) -> None:
        self._node = node
        self._own: Any = None  # the node made for the manager, if it is not ``node``
        if node.get_fully_qualified_name() == manager:
            # ros2_control's manager node allows undeclared parameters (rclpy has no
            # setter for it after construction)
            node._allow_undeclared_parameters = True
            self.node = node
        else:
            from rclpy.node import Node

            self._own = Node(basename(manager), namespace=namespace_of(manager),
                             context=node.context, allow_undeclared_parameters=True,
                             # not the runner's -r __node:=... (rt_runner's arguments)
                             use_global_arguments=False, enable_logger_service=False)
            if executor is not None:
                executor.add_node(self._own)
            self._executor = executor
            self.node = self._own

    def close(self) -> None:
        if self._own is not None:
            if self._executor is not None:
                self._executor.remove_node(self._own)
            self._own.destroy_node()
            self._own = None

    def _value(self, name: str) -> Any:
        if not self.node.has_parameter(name):
            return None
        value = self.node.get_parameter(name).value
        if isinstance(value, str) and value.lstrip().startswith("["):
            try:
                value = yaml.safe_load(value)
            except yaml.YAMLError:
                pass
        return value

    def controller(self, name: str) -> SetOnManager:
        """``<name>.type``, ``.params_file`` and ``.node_options_args`` as set; a
        ConfigurationError names one of the wrong type."""
        out = SetOnManager()
        type_name = self._value(f"{name}.type")
        if type_name is not None:
            if not isinstance(type_name, str):
                raise ConfigurationError(f"The 'type' param needs to be a string for '{name}'")
            out.type_name = type_name
        for key, attr in (("params_file", "params_files"),
                          ("node_options_args", "node_options_args")):
            value = self._value(f"{name}.{key}")
            if value is None or value == "":
                continue
            if isinstance(value, str):
                value = [value]
            if not isinstance(value, (list, tuple)) or not all(
                    isinstance(v, str) for v in value):
                raise ConfigurationError(f"The '{key}' param needs to be a string or a "
                                         f"string array for '{name}', but it is {value!r}")
            setattr(out, attr, [str(v) for v in value])
        return out
