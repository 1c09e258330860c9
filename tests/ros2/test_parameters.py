"""Tunable parameters and logger levels through the standard ROS 2 services.

Each component is a node of its own name in the graph, with its parameters
(``set_parameters``, ``describe_parameters``) and its logger services. A change is
validated in the supervisor and applied in the worker between two iterations.
"""


import pytest
from rcl_interfaces.msg import Log, LoggerLevel, Parameter, ParameterType
from rcl_interfaces.srv import (
    DescribeParameters,
    GetParameters,
    SetLoggerLevels,
    SetParameters,
)
from rclpy.parameter import Parameter as PyParameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from .._launches import tuned_launch
from .test_topics import FloatProbe, launched, spin_until

pytestmark = pytest.mark.integration

LAUNCH = tuned_launch(
    "rtcf_ros2_components", "/ros/in", "/ros/out", gain="2.0", label="first"
)


def call(node, srv_type, name, request, timeout=15.0):
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=timeout), f"no service {name}"
    future = client.call_async(request)
    assert spin_until(node, future.done, timeout=timeout), f"{name} did not answer"
    return future.result()


def set_params(node, **values):
    req = SetParameters.Request()
    req.parameters = [
        Parameter(name=k, value=PyParameter(k, value=v).get_parameter_value())
        for k, v in values.items()
    ]
    return call(node, SetParameters, "/ctl/tuned/set_parameters", req).results


@pytest.fixture
def tuned(tmp_path):
    with launched(tmp_path / "tuned.launch", text=LAUNCH) as proc:
        yield proc


def test_the_component_is_a_node_with_typed_described_parameters(ros_node, tuned):
    assert spin_until(
        ros_node, lambda: ("tuned", "/ctl") in ros_node.get_node_names_and_namespaces()
    ), ros_node.get_node_names_and_namespaces()
    got = call(ros_node, GetParameters, "/ctl/tuned/get_parameters",
               GetParameters.Request(names=["gain", "offset", "label"])).values
    assert got[0].type == ParameterType.PARAMETER_DOUBLE and got[0].double_value == 2.0
    assert got[1].type == ParameterType.PARAMETER_INTEGER and got[1].integer_value == 0
    assert got[2].string_value == "first"
    described = call(ros_node, DescribeParameters, "/ctl/tuned/describe_parameters",
                     DescribeParameters.Request(names=["gain", "mode", "label"])).descriptors
    assert described[0].description == "output per input"
    assert described[0].floating_point_range[0].to_value == 100.0
    assert "'linear', 'square'" in described[1].additional_constraints
    assert described[2].read_only  # read at configure time: changing it would do nothing


def test_a_parameter_set_while_running_changes_the_output(ros_node, tuned):
    probe = FloatProbe(ros_node, "/ros/in", "/ros/out")
    assert probe.answers(3.0, 6.0), probe.got[-3:]
    results = set_params(ros_node, gain=-1.5, offset=7)
    assert all(r.successful for r in results), [r.reason for r in results]
    assert probe.answers(3.0, -1.5 * 3.0 + 7), probe.got[-3:]
    assert set_params(ros_node, mode="square")[0].successful
    assert probe.answers(3.0, -1.5 * 9.0 + 7), probe.got[-3:]


@pytest.mark.parametrize(
    ("values", "reason"),
    [
        ({"gain": 1000.0}, ""),  # rclpy's own range check refuses it
        ({"mode": "cubic"}, "'cubic' is not one of 'linear', 'square'"),
        ({"label": "second"}, "read-only"),
        ({"gain": "high"}, ""),
    ],
)
def test_a_bad_value_is_refused_and_nothing_changes(ros_node, tuned, values, reason):
    results = set_params(ros_node, **values)
    assert not results[0].successful
    assert reason in results[0].reason
    got = call(ros_node, GetParameters, "/ctl/tuned/get_parameters",
               GetParameters.Request(names=["gain", "mode"])).values
    assert got[0].double_value == 2.0 and got[1].string_value == "linear"


def test_a_logger_level_change_filters_in_the_worker(ros_node, tuned):
    records = []
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    ros_node.create_subscription(Log, "/rosout", records.append, qos)
    mine = lambda level: [r for r in records if r.name == "ctl.tuned" and r.level == level]  # noqa: E731
    assert spin_until(ros_node, lambda: len(mine(20)) >= 2 and len(mine(30)) >= 2)
    res = call(ros_node, SetLoggerLevels, "/ctl/tuned/set_logger_levels",
               SetLoggerLevels.Request(levels=[LoggerLevel(name="ctl.tuned", level=30)]))
    assert res.results[0].successful, res.results[0].reason
    spin_until(ros_node, lambda: False, timeout=0.5)  # what was on its way arrives
    infos, warns = len(mine(20)), len(mine(30))
    assert spin_until(ros_node, lambda: len(mine(30)) >= warns + 5, timeout=10)
    assert len(mine(20)) == infos  # no info record made after the change
    bad = call(ros_node, SetLoggerLevels, "/ctl/tuned/set_logger_levels",
               SetLoggerLevels.Request(levels=[LoggerLevel(name="other", level=10)]))
    assert not bad.results[0].successful and "ctl.tuned" in bad.results[0].reason
