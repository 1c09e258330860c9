"""rt_runner and rt_launcher take the standard ROS 2 node arguments, and the graph shows
them as it shows any node: checked from this (separate) rclpy process.

--ros-args with -r/--remap (node-specific rules too), -p/--param, --params-file in
the standard format (``/**`` wildcards, fully qualified node names, nested values),
``__ns`` and ``__node``; node names and namespaces as ``ros2 node list`` shows them;
use_sim_time.
"""

import json
import textwrap

import pytest
from rcl_interfaces.srv import GetParameters
from std_msgs.msg import Int64
from std_srvs.srv import Trigger

from .._proc import end_after_each_test, wait_for
from ._clock import clock_publisher, step_clock
from .conftest import start_rtcf
from .test_nodes import STARTED, end, start
from .test_parameters import call
from .test_topics import FloatProbe, spin_until, stop, wait_running

pytestmark = pytest.mark.integration

RUNNER_PARAMS = """\
/**:
  ros__parameters:
    frequency: 100.0
    ros_mapping_whitelist: "/ros/.*"
/arm/arm_runner:
  ros__parameters:
    mode: no_wait
"""

LAUNCHER_PARAMS = """\
/**:
  ros__parameters:
    runner: /arm/arm_runner
/arm/tuned:
  ros__parameters:
    gain: 4.0
    label: from-the-file
    gains:
      kp: 1.5
      ki: 0.25
/arm/other:
  ros__parameters:
    gain: 99.0
"""


_end_all = end_after_each_test(STARTED, end)


def nodes(ros_node):
    return set(ros_node.get_node_names_and_namespaces())


def introspect(ros_node, runner):
    return json.loads(call(ros_node, Trigger, f"{runner}/introspect", Trigger.Request()).message)


def get_params(ros_node, node, *names):
    res = call(ros_node, GetParameters, f"{node}/get_parameters",
               GetParameters.Request(names=list(names)))
    return [v.double_value if v.type == 3 else v.string_value for v in res.values]


def test_params_files_remaps_and_names_as_the_ros2_tools_see_them(ros_node, tmp_path):
    runner_yaml = tmp_path / "runner.yaml"
    runner_yaml.write_text(RUNNER_PARAMS)
    launcher_yaml = tmp_path / "launcher.yaml"
    launcher_yaml.write_text(LAUNCHER_PARAMS)
    # the long forms, and -p over the file's /** value
    r = start("rt_runner", "--ros-args", "--remap", "__ns:=/arm", "--remap",
              "__node:=arm_runner", "--params-file", runner_yaml, "--param", "frequency:=250.0")
    wait_for(r, "ready: 250 Hz, mode no_wait")
    # a rule for this node only (tuned:in), and one for another node that must not apply
    la = start("rt_launcher", "rtcf_ros2_components", "Tuned", "--ros-args",
               "-r", "__ns:=/arm", "-r", "__node:=tuned", "--params-file", launcher_yaml,
               "-r", "tuned:in:=/ros/arm_in", "-r", "other:out:=/ros/wrong",
               "-r", "out:=/ros/arm_out", "-p", "offset:=1")
    wait_for(la, "loaded into /arm/arm_runner")

    # ros2 node list: each under its name and namespace, and the controller manager's
    # parameters node (where the Jazzy spawner sets <name>.type), nothing else of rtcf's
    expected = {("arm_runner", "/arm"), ("tuned", "/arm"), ("controller_manager", "/arm")}
    assert spin_until(ros_node, lambda: expected <= nodes(ros_node), timeout=20), \
        nodes(ros_node)
    assert {n for n in nodes(ros_node) if n[1] != "/"} == expected
    # the runner's settings came from the file, the wildcard and -p
    data = introspect(ros_node, "/arm/arm_runner")
    assert (data["runner"], data["frequency"], data["mode"]) == ("/arm/arm_runner", 250.0,
                                                                "no_wait")
    (component,) = data["components"]
    assert component["name"] == "/arm/tuned"
    # the component's parameters: its own entry of the file (nested values as a tree, as a
    # launch file gives them) and -p; none of the node's own (use_sim_time, ...)
    assert component["parameters"] == {
        "gain": 4.0, "label": "from-the-file", "gains": {"kp": 1.5, "ki": 0.25}, "offset": 1,
    }
    assert {t["name"]: t["value"] for t in component["tunables"]}["gain"] == 4.0
    assert [(p["name"], p["topic"]) for p in component["inputs"]] == [("in", "/ros/arm_in")]
    assert [(p["name"], p["topic"]) for p in component["outputs"]] == [("out", "/ros/arm_out")]
    assert get_params(ros_node, "/arm/tuned", "gain", "label") == [4.0, "from-the-file"]
    # and it computes with them: out = 4 * in + 1
    probe = FloatProbe(ros_node, "/ros/arm_in", "/ros/arm_out")
    assert probe.answers(2.0, 9.0), probe.got[-3:]
    end(la)
    wait_for(r, "unloaded /arm/tuned")


CLOCKED = """\
/**:
  ros__parameters:
    use_sim_time: true
    mode: no_wait
    frequency: 10.0
    ros_mapping_whitelist: "/ros/.*"
"""


def test_use_sim_time_makes_an_rt_runners_loop_follow_clock(ros_node, tmp_path):
    params = tmp_path / "clocked.yaml"
    params.write_text(CLOCKED)
    iterations = []
    ros_node.create_subscription(Int64, "/ros/sim_it", lambda m: iterations.append(m.data), 100)
    pub = clock_publisher(ros_node)
    r = start("rt_runner", "--ros-args", "-r", "__node:=sim_runner", "--params-file", params)
    wait_for(r, "ready: 10 Hz")
    la = start("rt_launcher", "rtcf_ros2_components", "TimeEcho", "--ros-args",
               "-r", "__node:=echo", "-p", "runner:=/sim_runner",
               "-r", "iteration:=/ros/sim_it", "-r", "time:=/ros/sim_t")
    wait_for(la, "loaded into")
    assert spin_until(ros_node, lambda: ros_node.count_publishers("/ros/sim_it") > 0)
    assert spin_until(ros_node, lambda: ros_node.count_subscribers("/clock") > 0)
    spin_until(ros_node, lambda: False, timeout=0.5)
    assert iterations == []  # no /clock yet: the loop waits
    step_clock(ros_node, pub, iterations, periods=5)  # 0.5 s of /clock
    assert iterations[-1] == 5  # /clock stopped: so did the loop


# and the controller manager's parameters node, as ros2_control's graph has it
SUM_TEST_NODES = {("rt_runner", "/rtcf"), ("sum1", "/rtcf"), ("sum2", "/rtcf"),
                  ("controller_manager", "/rtcf")}


def test_rtcf_launch_nodes_are_listed_under_their_names_and_namespaces(ros_node, tmp_path):
    launch = tmp_path / "ns.launch"
    launch.write_text(textwrap.dedent("""\
        <launch>
          <group ns="rtcf">
            <node name="rt_runner" pkg="rtcf" type="rt_runner">
              <param name="mode" value="no_wait"/>
              <param name="frequency" value="50.0"/>
            </node>
            <node name="sum1" pkg="rtcf" type="rt_launcher" args="rtcf_examples Mimo"/>
            <node name="sum2" pkg="rtcf" type="rt_launcher" args="rtcf_examples Mimo">
              <remap from="in1" to="out1"/>
              <remap from="out1" to="out3"/>
            </node>
          </group>
        </launch>
        """))
    proc = start_rtcf("launch", launch, "--middleware", "ros2")
    try:
        wait_running(proc)
        assert spin_until(ros_node, lambda: SUM_TEST_NODES <= nodes(ros_node)), nodes(ros_node)
        assert {n for n in nodes(ros_node) if n[1] != "/"} == SUM_TEST_NODES
    finally:
        stop(proc)
