"""What ``rt_runner --help`` and ``rt_launcher --help`` print, on ROS 1 and ROS 2.

Asked for before anything else (no node, no master, no worker): the node's arguments,
the parameters it takes (the runner's from :mod:`rtcf._core._settings`, so the list
cannot drift from what it reads), its services, and where the docs are.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence

from .._core._settings import parameter_help

HELP_FLAGS = ("-h", "--help")


def asks_for_help(argv: Sequence[str]) -> bool:
    """Whether -h or --help comes before the middleware's own arguments (``--ros-args``
    on ROS 2; ROS 1's ``name:=value`` are not flags)."""
    for word in argv[1:]:
        if word == "--ros-args":
            return False
        if word in HELP_FLAGS:
            return True
    return False


def help_printed(argv: Sequence[str], usage: Callable[[str], str], middleware: str) -> bool:
    """Whether ``argv`` asks for help; if so, the node's ``usage`` of ``middleware`` is
    printed (the nodes' first step: no middleware yet, no node, no master)."""
    if not asks_for_help(argv):
        return False
    print(usage(middleware))
    return True


def _parameters(rows: Sequence[tuple[str, str, str]]) -> list[str]:
    width = max(len(name) for name, _, _ in rows) + 2
    lines = []
    for name, default, meaning in rows:
        text = meaning + (f" [default: {default}]" if default else "")
        wrapped = textwrap.wrap(text, 88 - width - 2) or [""]
        lines.append(f"  {name.ljust(width)}{wrapped[0]}")
        lines.extend(f"  {' ' * width}{more}" for more in wrapped[1:])
    return lines


# what differs by middleware: how the node is called, and the docs of its middleware
_DOCS = {"ros2": "ros2.md", "ros1": "ros1.md"}
_RUNNER_USAGE = {
    "ros2": [
        "usage: rt_runner [-h] [--ros-args [-p NAME:=VALUE ...] [-r __node:=NAME] "
        "[-r __ns:=/NS]",
        "                 [--params-file FILE] [--log-level LEVEL]]",
        "       ros2 run rtcf rt_runner --ros-args -p frequency:=1000.0 -p mode:=no_wait",
    ],
    "ros1": [
        "usage: rt_runner [-h] [_NAME:=VALUE ...] [__name:=NAME] [__ns:=/NS]",
        "       rosrun rtcf rt_runner _frequency:=1000.0 _mode:=no_wait",
    ],
}
_RUNNER_SERVICES = {
    "ros2": [
        "  ~/load_component, ~/unload_component   rcl_interfaces/srv/SetParametersAtomically",
        "  ~/tune_component, ~/lifecycle_component rcl_interfaces/srv/SetParametersAtomically",
        "  ~/activate_rt_loop, ~/deactivate_rt_loop std_srvs/srv/Trigger "
        "(mode wait_for_trigger)",
    ],
    "ros1": [
        "  ~load_component, ~unload_component     rtcf_msgs/LoadComponent, UnloadComponent",
        "  ~activate_rt_loop, ~deactivate_rt_loop std_srvs/Trigger (mode wait_for_trigger)",
        "  ~get_runner_info, ~set_component_log_level",
    ],
}
# the parameters that only one middleware's runner reads
_RUNNER_EXTRA: dict[str, list[tuple[str, str, str]]] = {
    "ros2": [("robot_description", "", "the robot description (URDF); without it the runner "
              "reads the robot_description topic (docs/robot-description.md)")],
    "ros1": [("/use_sim_time", "", "(global) counts where the runner sets no use_sim_time")],
}


def runner_usage(middleware: str) -> str:
    """rt_runner's usage on ``ros2`` or ``ros1``."""
    text = [
        *_RUNNER_USAGE[middleware],
        "",
        "A real-time runner: it loads components (from rt_launcher nodes, or its load "
        "service),",
        "runs them in one loop in a worker process of its own, in their data-flow order, "
        "and maps",
        "their ports to ROS topics. Its parameters (the node's private ones):",
        "",
        *_parameters([*parameter_help(), *_RUNNER_EXTRA[middleware]]),
        "",
        "services:",
        *_RUNNER_SERVICES[middleware],
        "",
        f"docs: docs/runner.md and docs/{_DOCS[middleware]} in rtcf's source",
    ]
    return "\n".join(text)


# where each middleware's launcher looks for its runner when ~runner is not given
_LAUNCHER_RUNNER = {
    "ros2": ("runner", "/rt_runner", "the runner to load the component into"),
    "ros1": ("runner", "rt_runner", "the runner to load the component into; by default "
             "the nearest rt_runner from this node's namespace up to /"),
}
_LAUNCHER_USAGE = {
    "ros2": [
        "usage: rt_launcher [-h] MODULE CLASS [-f] [--ros-args [-r __node:=NAME] "
        "[-r FROM:=TO ...]",
        "                   [-p NAME:=VALUE ...] [--params-file FILE]]",
        "       ros2 run rtcf rt_launcher rtcf_examples Mimo --ros-args -r __node:=sum1 "
        "-r in1:=/in",
    ],
    "ros1": [
        "usage: rt_launcher [-h] MODULE CLASS [-f] [__name:=NAME] [FROM:=TO ...] "
        "[_NAME:=VALUE ...]",
        "       rosrun rtcf rt_launcher rtcf_examples Mimo __name:=sum1 in1:=/in",
    ],
}
_LAUNCHER_PARAMETERS = [
    ("is_first", "false", "the component starts a cycle (its inputs read the last "
     "iteration's values); also the flag -f"),
    ("autostart", "true", "false: configured but left inactive when the loop starts "
     "(a claimant of a command topic another controller holds; switch to it later)"),
    ("lane", "main", "the lane (a worker process of its own) it runs in"),
    ("rate", "", "its rate in Hz, a divisor of the runner's frequency"),
    ("update_rate", "0", "ros2_control's name of rate (0: the runner's frequency)"),
    ("every", "1", "run every this many iterations (instead of rate)"),
    ("phase", "", "the iteration in the period it runs in (0 .. every-1)"),
    ("cost_us", "", "its expected cost, for spreading phases"),
    ("on_error", "stop", "what an exception in update does: stop, deactivate or restart"),
    ("max_restarts", "3", "restarts on_error restart allows"),
    ("fallback", "", "a component (in this lane) that takes over its outputs when it "
     "fails"),
    ("deadline/NAME", "", "seconds: input NAME is past its deadline when its newest "
     "value is older"),
    ("on_deadline", "continue", "what an input past its deadline does: continue, "
     "deactivate or stop"),
    ("topics_ignore_for_graph", "", "a regex of topics left out of the data-flow order"),
    ("rt_package, rt_type", "", "MODULE and CLASS, when not given as arguments"),
    ("(any other)", "", "the component's own parameters (self.params)"),
]


def launcher_usage(middleware: str) -> str:
    """rt_launcher's usage on ``ros2`` or ``ros1``."""
    text = [
        *_LAUNCHER_USAGE[middleware],
        "",
        "Loads the class CLASS of the Python module MODULE into a runner as a component "
        "with this",
        "node's name, namespace, remaps and parameters; stays alive, and unloads it when "
        "stopped.",
        "",
        "arguments:",
        "  MODULE CLASS    the component's Python module and class (rtcf_examples Mimo)",
        "  -f, --is_first  the component starts a cycle",
        "",
        "parameters (the node's private ones):",
        *_parameters([_LAUNCHER_RUNNER[middleware], *_LAUNCHER_PARAMETERS]),
        "",
        f"docs: docs/launch-files.md and docs/{_DOCS[middleware]} in rtcf's source",
    ]
    return "\n".join(text)
