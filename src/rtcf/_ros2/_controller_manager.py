"""ros2_control's controller manager services, answered from a runner's components.

Tools that manage ros2_control controllers (``ros2 control list_controllers`` and
``switch_controllers``, rqt_controller_manager, a spawner's activation) call
``<controller_manager>/list_controllers`` and ``<controller_manager>/switch_controller``
(controller_manager_msgs). A runner under ROS 2 answers both for its components, so
those tools see and switch rtcf's controllers:

* every loaded component is a controller, named relative to the controller manager's
  namespace (as ros2_control's controllers are nodes there), with its lifecycle state,
  its type (the class's ``ros2_control_type``, as rtcf_controllers give it, else
  ``module.Class``), its rate, and ``is_async`` when it runs in a lane on logical
  execution time;
* a switch is the components' lifecycle transitions (``WorkerRunner.change_states``):
  the deactivations first, then the activations, all applied by the loop at the start
  of one iteration (of each worker: components in other lanes switch at their own
  worker's next iteration) while it runs on, as ros2_control applies a switch at one
  point of its loop. The checks are the controller manager's (Jazzy): an
  unknown name, activating one that is not inactive, deactivating one that is not
  active. ``STRICT`` refuses the whole request on any of them, and a transition that
  fails makes the worker undo those it made before the iteration's first update (all
  or nothing in that iteration; across lanes, each worker's share); ``BEST_EFFORT``
  (also for 0, ``AUTO`` and ``FORCE_AUTO``, as ros2_control falls back) leaves the
  offending ones out and goes on.
  Then, whatever the strictness, the claims (``add_output(..., claim=True)``): a
  controller to activate may not claim a command topic that a controller staying
  active holds, nor one another controller to activate claims; ``list_controllers``
  gives an active controller's claimed topics as its ``claimed_interfaces``.

Both run in the bridge's executor thread, as the components' lifecycle services do;
the worker never sees them other than as lifecycle transitions.
"""

from __future__ import annotations

from typing import Any

from .._core._errors import RtcfError
from .._core._lane_names import MAIN_LANE
from .._core._lifecycle import UNDONE
from .._core._names import expand, namespace_of
from .._runtime._supervisor import WorkerRunner
from ._controller_chains import fill, switch_order
from ._controller_loading import ControllerLoading
from ._hardware_services import HardwareServices

NOTHING_TO_DO = (
    "After checking the controllers, no controllers need to be activated or deactivated.")


def serve_controller_manager(
    node: Any, runner: WorkerRunner, name: str, executor: Any = None
) -> ControllerManager | None:
    """The services, where controller_manager_msgs imports (``bash scripts/setup-ros2``
    builds it; a ROS 2 installation has it); else none, said at debug level."""
    try:
        return ControllerManager(node, runner, name, executor)
    except ImportError as exc:
        node.get_logger().debug(
            f"no {name}/list_controllers nor switch_controller: {exc} (controller_manager_msgs "
            "is built by bash scripts/setup-ros2, docs/ros2.md)")
        return None


class ControllerManager:
    """The two services on ``node``, under ``name`` (relative to the node's namespace)."""

    def __init__(self, node: Any, runner: WorkerRunner, name: str, executor: Any = None
                 ) -> None:
        from controller_manager_msgs.msg import ChainConnection, ControllerState
        from controller_manager_msgs.srv import ListControllers, SwitchController

        self._node = node
        self._runner = runner
        self._state_msg = ControllerState
        self._connection = ChainConnection
        self._strict = SwitchController.Request.STRICT
        full = expand(name, node.get_namespace())
        self.name = full
        self._namespace = namespace_of(full)
        self._services = [
            node.create_service(ListControllers, f"{full}/list_controllers", self._list),
            node.create_service(SwitchController, f"{full}/switch_controller", self._switch),
        ]
        # load, configure, unload, list types: what a spawner needs besides these two
        # (and the manager's parameters that the spawner sets before it loads)
        self._loading = ControllerLoading(node, runner, full, executor)
        self._hardware = HardwareServices(node, runner, full)  # its list_hardware_* ...

    def close(self) -> None:
        self._loading.close()
        self._hardware.close()
        for service in self._services:
            self._node.destroy_service(service)
        self._services.clear()

    # -- names ------------------------------------------------------------------------
    def _short(self, component: str) -> str:
        """A component's controller name: relative to the manager's namespace."""
        ns = self._namespace.rstrip("/") + "/"
        return component[len(ns):] if component.startswith(ns) else component

    def _full(self, controller: str) -> str:
        return expand(controller, self._namespace)

    # -- list_controllers ---------------------------------------------------------------
    def _list(self, request: Any, response: Any) -> Any:
        frequency = self._runner.settings.frequency
        infos = self._by_name()
        for info in infos.values():
            every = int(info.get("every", 1)) or 1
            state = self._state_msg()
            state.name = self._short(str(info["name"]))
            state.state = str(info.get("lifecycle", "unknown"))
            state.type = str(info.get("ros2_control_type") or info.get("type", ""))
            state.is_async = info.get("lane", MAIN_LANE) != MAIN_LANE and every > 1
            state.update_rate = min(65535, max(0, round(frequency / every)))
            commands, states = info.get("interfaces", ((), ()))
            state.required_command_interfaces = [str(k) for k in commands]
            state.required_state_interfaces = [str(k) for k in states]
            if state.state == "active":  # what it holds: its interfaces' keys (with
                # hardware), else its claimed command topics
                hardware = getattr(self._runner, "hardware", None)
                state.claimed_interfaces = [str(t) for t in (
                    commands if hardware else info.get("claims", []))]
            fill(state, state.name, infos, self._connection)  # chained controllers
            response.controller.append(state)
        return response

    def _by_name(self) -> dict[str, Any]:
        return {self._short(str(c["name"])): c
                for c in self._runner.introspect().get("components", [])}

    # -- switch_controller --------------------------------------------------------------
    def _switch(self, request: Any, response: Any) -> Any:
        strict = request.strictness == self._strict
        timeout = request.timeout.sec + request.timeout.nanosec * 1e-9
        try:
            response.ok, response.message = self._do_switch(
                list(request.activate_controllers), list(request.deactivate_controllers),
                strict, timeout if timeout > 0 else None,
            )
        except RtcfError as exc:  # a locked runner, a transition that did not come back
            response.ok, response.message = False, str(exc)
        return response

    def _do_switch(
        self, activate: list[str], deactivate: list[str], strict: bool, timeout: float | None
    ) -> tuple[bool, str]:
        components = self._runner.introspect().get("components", [])
        states = {self._short(str(c["name"])): str(c.get("lifecycle", "")) for c in components}
        claims = {self._short(str(c["name"])): list(c.get("claims", [])) for c in components}
        problems: list[str] = []
        lists = []
        for action, names in (("deactivate", deactivate), ("activate", activate)):
            found = [n for n in names if n in states]
            for name in names:
                if name not in states:
                    problem = (f"Could not {action} controller with name '{name}' because no "
                               "controller with this name exists")
                    if strict:
                        return False, problem
                    problems.append(problem)
            if names and not found:  # best effort: none of a list exists
                return False, "\n".join(problems)
            lists.append(found)
        to_deactivate, to_activate = lists
        for name in list(to_activate):
            state = states[name]
            problem = ""
            if state == "unconfigured":
                problem = (f"Controller with name '{name}' is in 'unconfigured' state. The "
                           "controller needs to be configured to be in 'inactive' state before "
                           "it can be checked and activated.")
            elif state == "active" and name not in to_deactivate:
                problem = f"Controller with name '{name}' is already active."
            elif state not in ("inactive", "active"):
                problem = (f"Controller with name '{name}' is not in 'inactive' state. The "
                           "controller needs to be in 'inactive' state before it can be "
                           "checked and activated.")
            if problem:
                if strict:
                    return False, problem
                to_activate.remove(name)
        for name in list(to_deactivate):
            if states[name] != "active":
                problem = (f"Controller with name '{name}' can not be deactivated since it is "
                           "not active.")
                if strict:
                    return False, problem
                to_deactivate.remove(name)
        if not to_activate and not to_deactivate:
            return True, NOTHING_TO_DO
        conflict = _claim_conflict(to_activate, to_deactivate, states, claims)
        if conflict:  # refused whatever the strictness, as ros2_control does
            return False, conflict
        to_deactivate, to_activate = switch_order(to_deactivate, to_activate, self._by_name())
        return self._transitions(to_deactivate, to_activate, strict, timeout)

    def _transitions(
        self, to_deactivate: list[str], to_activate: list[str], strict: bool,
        timeout: float | None,
    ) -> tuple[bool, str]:
        """Deactivations, then activations, all at the start of one iteration of each
        worker; STRICT: all or nothing, a failure undone by the worker in that iteration."""
        steps = [(n, "deactivate") for n in to_deactivate] + [(n, "activate") for n in to_activate]
        outcomes = self._runner.change_states(
            [(self._full(name), transition) for name, transition in steps], timeout, strict)
        done = [step for step, outcome in zip(steps, outcomes, strict=True) if outcome.ok]
        failed = [f"Could not {transition} controller '{name}': {o.reason or o.result}"
                  for (name, transition), o in zip(steps, outcomes, strict=True)
                  if not o.ok and o.result != UNDONE]
        if failed and strict:
            # each worker undid its own share (rtcf._core._switching); what one could not
            # undo is said
            failed += [f"Could not {transition} controller '{name}' back: {o.reason}"
                       for (name, transition), o in zip(steps, outcomes, strict=True)
                       if o.result == UNDONE and o.start != o.end]
            # the share of another lane's worker that had nothing fail was made whole: it
            # is undone now, an iteration or more later (a switch across lanes)
            undo = {"activate": "deactivate", "deactivate": "activate"}
            back = [(name, undo[made]) for name, made in reversed(done)]
            undone = self._runner.change_states(
                [(self._full(name), transition) for name, transition in back], timeout
            ) if back else []
            failed += [f"Could not {transition} controller '{name}' back: {o.reason or o.result}"
                       for (name, transition), o in zip(back, undone, strict=True) if not o.ok]
            return False, "\n".join(failed) + "; the switch was undone ('STRICT' switch)"
        if failed and not done:
            return False, "\n".join(failed)
        return True, "\n".join(failed)


def _claim_conflict(
    to_activate: list[str], to_deactivate: list[str], states: dict[str, str],
    claims: dict[str, list[str]],
) -> str:
    """Why the switch may not run ("" if it may): a controller to activate claims a
    command topic that one staying active holds, or that another one to activate claims
    too (the controller manager's availability check, its words, with the holder)."""
    held = {topic: name for name, state in states.items()
            if state == "active" and name not in to_deactivate for topic in claims[name]}
    coming: dict[str, str] = {}
    for name in to_activate:
        if name in to_deactivate:  # restarted: it keeps what it holds
            continue
        for topic in claims[name]:
            if topic in held:
                return (f"Unable to activate controller '{name}' since the command interface "
                        f"'{topic}' is currently claimed by another controller ('{held[topic]}').")
            if topic in coming:
                return (f"Unable to activate controller '{name}' since the command interface "
                        f"'{topic}' will be used by another controller that is being activated "
                        f"('{coming[topic]}').")
            coming[topic] = name
    return ""
