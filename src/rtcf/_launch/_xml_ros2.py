"""ROS 2 launch XML's own elements and attributes, as the launch XML reader reads them.

ROS 2 launch files set launch configurations with ``<let>``, push namespaces with
``<push-ros-namespace>``, remap and set the environment with ``<set_remap>`` and
``<set_env>`` (each also spelled with a dash), and give a ``<node>``'s ``<param
from=>`` a parameters file, whose node-name keys may hold wildcards.
``<set_parameter>`` is not supported yet. Untyped values of ROS 2 nodes are typed
as ROS 2 launch does (:func:`infer_ros2`). The walk and the elements both
dialects share are in :mod:`._xml`.
"""

from __future__ import annotations

from typing import Any

import yaml

from .._core._errors import ConfigurationError, LaunchError
from ._description import NodeDescription
from ._ros_parameters import params_key_matches, sections_of
from ._xml_reading import Config, Element, Handler, Reader, Scope


def infer_ros2(value: str) -> Any:
    """ROS 2 launch: YAML-style inference limited to bool, int and float, and lists
    of one of them (ROS 2 parameters' arrays)."""
    lowered = value.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        loaded = yaml.safe_load(value)
    except yaml.YAMLError:
        return value
    if isinstance(loaded, (int, float)) and not isinstance(loaded, bool):
        return loaded
    if isinstance(loaded, list) and loaded and len({type(v) for v in loaded}) == 1:
        if isinstance(loaded[0], (bool, int, float, str)):  # value="[1.0, 2.0]": an array
            return loaded
    return value


class Ros2Tags:
    """The ROS 2 elements the reader dispatches to, and a <param from=> parameters file."""

    def __init__(self, reader: Reader) -> None:
        self._reader = reader
        self.handlers: dict[str, Handler] = {
            "let": self._let,
            "set_remap": reader.remap,
            "set-remap": reader.remap,
            "set_env": reader.env,
            "set-env": reader.env,
            "push-ros-namespace": self._push_ros_namespace,
            "push_ros_namespace": self._push_ros_namespace,
            "set_parameter": self._not_supported,
            "set-parameter": self._not_supported,
        }

    def _let(self, element: Element, scope: Scope) -> None:
        name = self._reader.required(element, scope, "name")
        scope.configs[name] = Config(self._reader.required(element, scope, "value"))

    def _push_ros_namespace(self, element: Element, scope: Scope) -> None:
        raw = self._reader.required(element, scope, "namespace")
        scope.namespace = self._reader.namespace(raw, scope.namespace, element, scope)

    def params_file(self, element: Element, scope: Scope, node: NodeDescription | None) -> None:
        if node is None:
            raise self._reader.error(
                "<param from=...> is only allowed inside a <node>", element, scope
            )
        path = self._reader.path(self._reader.required(element, scope, "from"), scope)
        data = self._reader.parse_yaml(
            self._reader.read_text(path, element, scope), element, scope, file=path
        )
        node.params_files.append(path)
        # the one reader of ros__parameters files (the controller manager's too)
        try:
            sections = sections_of(data, path)
        except ConfigurationError as exc:
            raise LaunchError(exc.message, file=path) from None
        for key, tree in sections.items():
            if params_key_matches(key, node.full_name):
                self._reader.set_tree(node.full_name, tree)

    def _not_supported(self, element: Element, scope: Scope) -> None:
        raise self._reader.error(f"<{element.tag}> is not supported yet", element, scope)
