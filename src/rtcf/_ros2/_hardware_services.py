"""ros2_control's controller manager services about the hardware, answered from the
supervisor's view of it (rtcf._runtime._hardware_view; the resource manager lives in
the worker): ``list_hardware_components``, ``list_hardware_interfaces`` and
``set_hardware_component_state`` (applied by the loop between two iterations, answered
as ros2_control answers: ``ok`` and the state the hardware is in)."""

from __future__ import annotations

from typing import Any

from .._runtime._supervisor import WorkerRunner


class HardwareServices:
    """The three services on ``node`` under the controller manager's full name."""

    def __init__(self, node: Any, runner: WorkerRunner, full: str) -> None:
        from controller_manager_msgs.msg import HardwareComponentState, HardwareInterface
        from controller_manager_msgs.srv import (
            ListHardwareComponents,
            ListHardwareInterfaces,
            SetHardwareComponentState,
        )

        self._node = node
        self._runner = runner
        self._component = HardwareComponentState
        self._interface = HardwareInterface
        self._services = [
            node.create_service(ListHardwareComponents, f"{full}/list_hardware_components",
                                self._components),
            node.create_service(ListHardwareInterfaces, f"{full}/list_hardware_interfaces",
                                self._interfaces),
            node.create_service(SetHardwareComponentState,
                                f"{full}/set_hardware_component_state", self._set_state),
        ]

    def close(self) -> None:
        for service in self._services:
            self._node.destroy_service(service)
        self._services.clear()

    def _view(self) -> Any:
        return getattr(self._runner, "hardware", None)

    def _interface_msg(self, given: tuple[str, str, bool, bool]) -> Any:
        msg = self._interface()
        msg.name, msg.data_type, msg.is_available, msg.is_claimed = given
        return msg

    def _components(self, request: Any, response: Any) -> Any:
        view = self._view()
        for c in view.list_components() if view else []:
            msg = self._component()
            msg.name, msg.type, msg.plugin_name = c["name"], c["type"], c["plugin_name"]
            msg.class_type = c["plugin_name"]  # (deprecated: the plugin's name)
            msg.is_async, msg.rw_rate = bool(c["is_async"]), min(65535, int(c["rw_rate"]))
            msg.state.id, msg.state.label = c["state"]
            msg.command_interfaces = [self._interface_msg(i) for i in c["command_interfaces"]]
            msg.state_interfaces = [self._interface_msg(i) for i in c["state_interfaces"]]
            response.component.append(msg)
        return response

    def _interfaces(self, request: Any, response: Any) -> Any:
        view = self._view()
        if view:
            commands, states = view.list_interfaces()
            response.command_interfaces = [self._interface_msg(i) for i in commands]
            response.state_interfaces = [self._interface_msg(i) for i in states]
        return response

    def _set_state(self, request: Any, response: Any) -> Any:
        view = self._view()
        target = request.target_state
        if not view or request.name not in view.components:
            self._node.get_logger().error(
                f"hardware component with name '{request.name}' does not exist")
            response.ok = False
            return response
        try:
            ok, state, label = view.set_state(
                request.name, target.id if target.id else target.label)
        except Exception as exc:  # a locked runner: refused, said
            self._node.get_logger().error(f"set_hardware_component_state: {exc}")
            ok, state = False, int(view.components[request.name]["state"])
            label = ""

        response.ok = ok
        response.state.id, response.state.label = state, label
        return response
