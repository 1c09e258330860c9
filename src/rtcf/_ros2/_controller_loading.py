"""ros2_control's load, configure, unload and list-types services, on a runner.

A ros2_control spawner (``ros2 run controller_manager spawner NAME``) and ``ros2
control load_controller`` call, on the controller manager:
``list_controllers`` (is it loaded?), ``load_controller``, ``configure_controller``
and then ``switch_controller`` to activate it. The first and the last are
:mod:`._controller_manager`'s; this module answers the others, as ros2_control's
controller manager (Jazzy) does:

* ``load_controller``: the type is the ``<name>.type`` of the controller manager's
  section in the runner's ``--params-file`` (:mod:`.._launch._controller_setup`), the
  class is the one installed under that type (:mod:`.._launch._controller_types`,
  the entry-point group ``rtcf.controllers``). The runner loads it while its loop
  runs, as an rt_launcher's component (its main thread's request queue), named
  ``name`` in the controller manager's namespace, with its parameters from the
  section of its own node name. It is loaded unconfigured
  (``ComponentSpec.unconfigured``): constructed, its parameters set, its
  ``configure`` not run, no ports yet, never started by the loop on its own; as
  ros2_control leaves it (on_init, no on_configure).
* ``configure_controller``: the lifecycle ``configure`` (``cleanup`` first from
  ``inactive``, as ros2_control does). The first one declares the controller's
  ports, so it is served between two runs as a load is (the graph resolved again).
* ``unload_controller``: refused while the controller is active.
* ``list_controller_types``: every installed type.

Answers are ``ok`` only, as ros2_control's; why a request failed is logged on the
runner's node (and so on /rosout) in ros2_control's words.
"""

from __future__ import annotations

from typing import Any

from .._core._errors import ConfigurationError, RtcfError
from .._core._names import expand, namespace_of
from .._launch._controller_specs import controller_params, controller_spec, node_options
from .._launch._controller_types import controller_types, resolve
from .._runtime._supervisor import WorkerRunner
from ._controller_parameters import ManagerParameters

BASE_CLASS = "controller_interface::ControllerInterface"


class ControllerLoading:
    """The four services of controller manager ``manager`` (its full name) on ``node``."""

    def __init__(self, node: Any, runner: WorkerRunner, manager: str, executor: Any = None
                 ) -> None:
        from controller_manager_msgs.srv import (
            ConfigureController,
            ListControllerTypes,
            LoadController,
            UnloadController,
        )

        self._node = node
        self._runner = runner
        self._log = node.get_logger()
        self._namespace = namespace_of(manager)
        self._manager = manager
        # <name>.type, .params_file, .node_options_args: set by the Jazzy spawner
        self._parameters = ManagerParameters(node, manager, executor)
        self.services = [
            node.create_service(LoadController, f"{manager}/load_controller", self._load),
            node.create_service(
                ConfigureController, f"{manager}/configure_controller", self._configure),
            node.create_service(UnloadController, f"{manager}/unload_controller", self._unload),
            node.create_service(
                ListControllerTypes, f"{manager}/list_controller_types", self._types),
        ]

    def close(self) -> None:
        self._parameters.close()
        for service in self.services:
            self._node.destroy_service(service)
        self.services.clear()

    def _state(self, name: str) -> str | None:
        """A controller's lifecycle state, None if no controller has this name."""
        info = self._runner.components.get(expand(name, self._namespace))
        return None if info is None else str(info.get("lifecycle", "unknown"))

    def _error(self, text: str) -> bool:
        self._log.error(text)
        return False

    # -- the services ----------------------------------------------------------------
    def _types(self, request: Any, response: Any) -> Any:
        response.types = controller_types()
        response.base_classes = [BASE_CLASS] * len(response.types)
        return response

    def _load(self, request: Any, response: Any) -> Any:
        response.ok = self._do_load(str(request.name))
        return response

    def _configure(self, request: Any, response: Any) -> Any:
        response.ok = self._do_configure(str(request.name))
        return response

    def _unload(self, request: Any, response: Any) -> Any:
        response.ok = self._do_unload(str(request.name))
        return response

    # -- what they do ----------------------------------------------------------------
    def _do_load(self, name: str) -> bool:
        self._log.info(f"Loading controller '{name}'")
        if self._state(name) is not None:
            return self._error(
                f"A controller named '{name}' was already loaded inside the controller manager")
        setup = self._runner.controller_setup
        full = expand(name, self._namespace)
        try:  # what the spawner set on the manager, else the runner's files
            given = self._parameters.controller(name)
            options = node_options(given.node_options_args)
            params = controller_params(full, self._manager, setup, given.params_files,
                                       options)
        except ConfigurationError as exc:
            return self._error(f"Could not load controller '{name}': {exc}")
        type_name = given.type_name or (setup.types.get(name, "") if setup is not None else "")
        if not type_name:
            return self._error(f"The 'type' param was not defined for '{name}'.")
        try:
            resolve(type_name)
        except RtcfError as exc:
            self._error(f"Loader for controller '{name}' (type '{type_name}') not found.")
            self._log.info(f"Available classes: {', '.join(controller_types())} ({exc})")
            return False
        queue = self._runner.requests
        if queue is None:
            return self._error(
                f"Could not load controller '{name}': runner {self._runner.name} takes no "
                "load requests")
        try:
            spec = controller_spec(name, self._namespace, type_name, params,
                                   remaps=options.remaps, autostart=False, unconfigured=True)
            self._runner.admits("loads", spec.module, full, spec.class_name)
        except RtcfError as exc:
            return self._error(f"Could not load controller '{name}': {exc}")
        done = queue.submit("load", spec)
        if not done.ok:
            return self._error(f"Could not load controller '{name}': {done.reason}")
        return True

    def _found(self, name: str, verb: str, doing: str) -> str | None:
        """The controller's state, ``doing`` logged first; None (and the error logged)
        when no controller has this name."""
        self._log.info(f"{doing} controller: '{name}'")
        state = self._state(name)
        if state is None:
            self._error(f"Could not {verb} controller with name '{name}' because no "
                        "controller with this name exists")
        return state

    def _do_configure(self, name: str) -> bool:
        state = self._found(name, "configure", "Configuring")
        if state is None:
            return False
        if state in ("active", "finalized"):
            return self._error(f"Controller '{name}' can not be configured from '{state}' state.")
        if state == "inactive" and not self._transition(name, "cleanup", "configure"):
            return False
        # the first one declares the ports: served between two runs as a load is
        # (WorkerRunner.change_state)
        return self._transition(name, "configure", "configure")

    def _do_unload(self, name: str) -> bool:
        state = self._found(name, "unload", "Unloading")
        if state is None:
            return False
        if state == "active":
            return self._error(
                f"Could not unload controller with name '{name}' because it is still active")
        queue = self._runner.requests
        if queue is None:
            return self._error(f"Could not unload controller '{name}': runner "
                               f"{self._runner.name} takes no unload requests (rtcf launch)")
        done = queue.submit("unload", expand(name, self._namespace))
        return done.ok or self._error(f"Could not unload controller '{name}': {done.reason}")

    def _transition(self, name: str, transition: str, what: str) -> bool:
        try:
            outcome = self._runner.change_state(expand(name, self._namespace), transition)
        except RtcfError as exc:
            return self._error(f"Could not {what} controller '{name}': {exc}")
        if outcome.ok:
            return True
        state = self._state(name)
        if what == "configure":
            return self._error(f"After configuring, controller '{name}' is in state "
                               f"'{state}' , expected inactive.")
        return self._error(f"Could not {what} controller '{name}': "
                           f"{transition}: {outcome.reason or outcome.result}")
