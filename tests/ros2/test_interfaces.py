"""The interface packages that PyPI lacks, as scripts/setup-ros2 builds them.

control_msgs, controller_manager_msgs and tf2_msgs are built from their Jazzy releases'
definitions (ros2_interfaces/README.md). Their fields are those of the definitions, their
messages survive rclpy's serializer, a FollowJointTrajectory goal goes from an rclpy
ActionClient to an ActionServer in another process and comes back with feedback and a
result, and their type hashes (RIHS01, which rosidl computes from the definitions and DDS
carries in the graph) are the ones Jazzy's own packages have, so that MoveIt, nav2 and
`ros2 topic info` see the same types.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rclpy
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory  # fails loudly where it is missing
from control_msgs.msg import (
    JointTolerance,
    JointTrajectoryControllerState,
    MultiDOFCommand,
    MultiDOFStateStamped,
)
from controller_manager_msgs.msg import ControllerState
from controller_manager_msgs.srv import ListControllers, SwitchController
from geometry_msgs.msg import TransformStamped
from rclpy.action import ActionClient
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectoryPoint

from .._proc import read_rest, wait_for
from .conftest import FIXTURES, rtcf_env
from .test_topics import spin_until

# RIHS01 type hashes. TFMessage, TF2Error and JointTrajectoryControllerState are those that
# Jazzy systems with the packages from their installer report (`ros2 topic info -v`); the
# others are what rosidl computes from the definitions in ros2_interfaces/, pinned here so
# that a change of a definition (or of rosidl's hashing) shows.
HASHES = {
    "tf2_msgs/msg/TFMessage":
        "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "tf2_msgs/msg/TF2Error":
        "RIHS01_db2485e7d6a0ec75bf087e058ee45df682acc3a621ca7780503d10aac141809a",
    "control_msgs/msg/JointTrajectoryControllerState":
        "RIHS01_51d8dd89cc624cbe9daaeeb4d80d6de9b86168ffdc3be41fefc0953e3c26e480",
    "control_msgs/msg/MultiDOFCommand":
        "RIHS01_033fb0fa1ffc63a872ca73c61a49ded83a22daa5cc3f074cc28949f73359e677",
    "control_msgs/msg/MultiDOFStateStamped":
        "RIHS01_08e47e3e734a7d08131b57e14e9f740782f3bf9a1aadabd2a16b54d27e551f0a",
    "control_msgs/action/FollowJointTrajectory":
        "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6",
    "control_msgs/action/FollowJointTrajectory_Goal":
        "RIHS01_8a9060704b269608f5a340934cc26e66869dd14bdac29e2e7fd9ec8b9882d205",
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage":
        "RIHS01_80398fcb9674a79081a9906e2ccf0c804dd7cb15e22e362e606ee87186beab71",
    "controller_manager_msgs/srv/ListControllers":
        "RIHS01_4f8e36bb1fa5afdeba45c2d56ae6a2097b1493a253f961dd6290c085033bd189",
    "controller_manager_msgs/srv/SwitchController":
        "RIHS01_d4ad10aa5da7808bc522d55d4123d8ef79de73d049d165639d7663ac37cc9895",
}


def _share(package):
    """The package's share directory in the prefix its Python package was installed into."""
    for prefix in (*os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep), sys.prefix):
        if prefix and (Path(prefix) / "share" / package / "package.xml").is_file():
            return Path(prefix) / "share" / package
    raise AssertionError(f"no share/{package}/package.xml in AMENT_PREFIX_PATH or {sys.prefix}")


def test_fields_are_those_of_the_definitions():
    goal = FollowJointTrajectory.Goal.get_fields_and_field_types()
    assert goal == {
        "trajectory": "trajectory_msgs/JointTrajectory",
        "multi_dof_trajectory": "trajectory_msgs/MultiDOFJointTrajectory",
        "path_tolerance": "sequence<control_msgs/JointTolerance>",
        "component_path_tolerance": "sequence<control_msgs/JointComponentTolerance>",
        "goal_tolerance": "sequence<control_msgs/JointTolerance>",
        "component_goal_tolerance": "sequence<control_msgs/JointComponentTolerance>",
        "goal_time_tolerance": "builtin_interfaces/Duration",
    }
    result = FollowJointTrajectory.Result
    assert result.get_fields_and_field_types() == {"error_code": "int32", "error_string": "string"}
    assert (result.SUCCESSFUL, result.INVALID_GOAL, result.INVALID_JOINTS) == (0, -1, -2)
    assert (result.OLD_HEADER_TIMESTAMP, result.PATH_TOLERANCE_VIOLATED) == (-3, -4)
    assert result.GOAL_TOLERANCE_VIOLATED == -5
    feedback = FollowJointTrajectory.Feedback.get_fields_and_field_types()
    assert list(feedback) == [
        "header", "joint_names", "desired", "actual", "error",
        "multi_dof_joint_names", "multi_dof_desired", "multi_dof_actual", "multi_dof_error",
    ]
    assert feedback["actual"] == "trajectory_msgs/JointTrajectoryPoint"
    assert JointTolerance.get_fields_and_field_types() == {
        "name": "string", "position": "double", "velocity": "double", "acceleration": "double",
    }
    state = JointTrajectoryControllerState.get_fields_and_field_types()
    assert list(state) == [
        "header", "joint_names", "reference", "feedback", "error", "output",
        "multi_dof_joint_names", "multi_dof_reference", "multi_dof_feedback", "multi_dof_error",
        "multi_dof_output", "speed_scaling_factor",
    ]
    assert MultiDOFCommand.get_fields_and_field_types() == {
        "dof_names": "sequence<string>", "values": "sequence<double>",
        "values_dot": "sequence<double>",
    }
    assert MultiDOFStateStamped.get_fields_and_field_types() == {
        "header": "std_msgs/Header", "dof_states": "sequence<control_msgs/SingleDOFState>",
    }
    assert TFMessage.get_fields_and_field_types() == {
        "transforms": "sequence<geometry_msgs/TransformStamped>",
    }
    assert ListControllers.Request.get_fields_and_field_types() == {}
    assert ListControllers.Response.get_fields_and_field_types() == {
        "controller": "sequence<controller_manager_msgs/ControllerState>",
    }
    assert list(ControllerState.get_fields_and_field_types())[:5] == [
        "name", "state", "type", "is_async", "update_rate",
    ]
    switch = SwitchController.Request
    assert switch.get_fields_and_field_types() == {
        "activate_controllers": "sequence<string>",
        "deactivate_controllers": "sequence<string>",
        "strictness": "int32",
        "activate_asap": "boolean",
        "timeout": "builtin_interfaces/Duration",
    }
    assert (switch.BEST_EFFORT, switch.STRICT, switch.AUTO, switch.FORCE_AUTO) == (1, 2, 3, 4)
    assert SwitchController.Response.get_fields_and_field_types() == {
        "ok": "boolean", "message": "string",
    }


def _goal():
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ["shoulder", "elbow"]
    goal.trajectory.points = [
        JointTrajectoryPoint(
            positions=[0.1 * i, -0.2 * i], velocities=[0.0, 0.0],
            time_from_start=Duration(sec=i, nanosec=250_000_000),
        )
        for i in range(1, 4)
    ]
    goal.goal_tolerance = [JointTolerance(name="elbow", position=0.01)]
    goal.goal_time_tolerance = Duration(sec=0, nanosec=500_000_000)
    return goal


def test_messages_survive_the_serializer():
    goal = _goal()
    back = deserialize_message(serialize_message(goal), FollowJointTrajectory.Goal)
    assert back == goal
    assert back.trajectory.points[2].time_from_start == Duration(sec=3, nanosec=250_000_000)
    np.testing.assert_array_equal(back.trajectory.points[1].positions, [0.2, -0.4])
    assert back.goal_tolerance[0].name == "elbow"

    tf = TransformStamped(child_frame_id="base_link")
    tf.header.frame_id = "odom"
    tf.transform.translation.x = 1.5
    tf.transform.rotation.w = 1.0
    message = TFMessage(transforms=[tf, TransformStamped(child_frame_id="wheel")])
    back = deserialize_message(serialize_message(message), TFMessage)
    assert back == message
    assert [t.child_frame_id for t in back.transforms] == ["base_link", "wheel"]


@pytest.mark.parametrize("name", sorted(HASHES))
def test_type_hashes_are_jazzys(name):
    """The hash rosidl wrote into share/<pkg>/<kind>/<Type>.json when it built the package."""
    package, kind, type_name = name.split("/")
    stem = type_name.split("_")[0]
    description = json.loads((_share(package) / kind / f"{stem}.json").read_text())
    hashes = {t["type_name"]: t["hash_string"] for t in description["type_hashes"]}
    assert hashes[name] == HASHES[name]


def _spin(node, future, timeout):
    executor = rclpy.executors.SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        executor.spin_until_future_complete(future, timeout_sec=timeout)
    finally:
        executor.remove_node(node)
    assert future.done(), "no answer in time"
    return future.result()


def test_the_graph_carries_the_same_hashes(ros_node):
    """What the built type supports give DDS, as `ros2 topic info -v` would show it."""
    for topic, message in [
        ("tf", TFMessage),
        ("controller_state", JointTrajectoryControllerState),
        ("commands", MultiDOFCommand),
        ("dof_state", MultiDOFStateStamped),
    ]:
        ros_node.create_publisher(message, f"~/{topic}", 1)
        (info,) = ros_node.get_publishers_info_by_topic(
            f"/{ros_node.get_name()}/{topic}"
        )
        assert str(info.topic_type_hash) == HASHES[info.topic_type], topic


@pytest.mark.integration
def test_follow_joint_trajectory_between_two_processes(ros_node):
    name = f"/rtcf_test_{os.getpid()}/follow_joint_trajectory"
    server = subprocess.Popen(
        [sys.executable, str(FIXTURES / "fjt_action_server.py"), name],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        env=rtcf_env(),
    )
    try:
        wait_for(server, "ready", timeout=60)
        client = ActionClient(ros_node, FollowJointTrajectory, name)
        assert client.wait_for_server(timeout_sec=30)
        feedback = []
        handle = _spin(
            ros_node,
            client.send_goal_async(_goal(), feedback_callback=lambda m: feedback.append(m)),
            timeout=30,
        )
        assert handle.accepted
        result = _spin(ros_node, handle.get_result_async(), timeout=30)
        assert result.status == GoalStatus.STATUS_SUCCEEDED
        assert result.result.error_code == FollowJointTrajectory.Result.SUCCESSFUL
        assert result.result.error_string == "shoulder,elbow: 3 points"
        # feedback and result travel on different channels: the rest of the feedback may
        # come just after the result
        assert spin_until(ros_node, lambda: len(feedback) == 3, timeout=10), feedback
        assert all(m.goal_id == handle.goal_id for m in feedback)
        assert feedback[0].feedback.joint_names == ["shoulder", "elbow"]
        assert feedback[0].feedback.header.frame_id == "fjt_action_server"
        positions = [list(m.feedback.actual.positions) for m in feedback]
        np.testing.assert_allclose(positions, [[0.1, -0.2], [0.2, -0.4], [0.3, -0.6]])
        # the action's feedback topic in the graph, with the FeedbackMessage's hash
        (info,) = ros_node.get_publishers_info_by_topic(f"{name}/_action/feedback")
        assert str(info.topic_type_hash) == HASHES[info.topic_type]
        client.destroy()
    finally:
        server.terminate()
        _, err = read_rest(server, timeout=30)
    assert server.returncode in (0, -15), err
