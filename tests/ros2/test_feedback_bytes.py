"""An action's feedback published from CDR bytes through rclpy's action server's own
publisher (rtcf._ros2._feedback_bytes), in this process: no rtcf process to start."""

from __future__ import annotations

from rclpy.action import ActionServer
from rclpy.serialization import serialize_message
from test_msgs.action import Fibonacci, NestedMessage

from rtcf._ros2._feedback_bytes import FEEDBACK_SUFFIX, feedback_bytes

from ._action_client import action_client


def _served(node, action_type, name, handles):
    def accepted(handle):
        handles.append(handle)  # kept open: the test publishes its feedback

    return ActionServer(node, action_type, name, lambda h: action_type.Result(),
                        handle_accepted_callback=accepted)


def test_bytes_reach_the_client_as_its_goals_feedback_in_order(ros_node):
    handles = []
    server = _served(ros_node, Fibonacci, "fib_bytes", handles)
    raw = feedback_bytes(server, 1024)
    assert raw is not None  # the server's own publisher was found and checked
    with action_client(ros_node, Fibonacci, "fib_bytes") as client:
        got = []
        goal = client.wait(client.send_goal_async(
            Fibonacci.Goal(order=3), feedback_callback=lambda m: got.append(m)))
        assert goal.accepted and client.until(lambda: bool(handles))
        uuid = bytes(handles[0].goal_id.uuid)
        for n in range(1, 6):
            assert raw.publish(uuid, serialize_message(Fibonacci.Feedback(sequence=range(n))))
        assert client.until(lambda: len(got) == 5)
        assert [list(m.feedback.sequence) for m in got] == [list(range(n)) for n in range(1, 6)]
        assert all(bytes(m.goal_id.uuid) == uuid for m in got)
        # no second writer: the graph sees the server's feedback publisher only
        topic = f"{ros_node.get_namespace().rstrip('/')}/fib_bytes{FEEDBACK_SUFFIX}"
        assert ros_node.count_publishers(topic) == 1
    server.destroy()


def test_a_nested_feedback_goes_on_unchanged_after_the_uuid(ros_node):
    handles = []
    server = _served(ros_node, NestedMessage, "nested_bytes", handles)
    raw = feedback_bytes(server, 1024)
    assert raw is not None
    feedback = NestedMessage.Feedback()
    feedback.nested_field.float64_value = 2.5
    feedback.nested_field.int8_value = -3
    feedback.nested_different_pkg.sec = 7
    with action_client(ros_node, NestedMessage, "nested_bytes") as client:
        got = []
        goal = client.wait(client.send_goal_async(
            NestedMessage.Goal(), feedback_callback=lambda m: got.append(m.feedback)))
        assert goal.accepted and client.until(lambda: bool(handles))
        assert raw.publish(bytes(handles[0].goal_id.uuid), serialize_message(feedback))
        assert client.until(lambda: bool(got))
        assert got[0] == feedback
    server.destroy()


def test_no_publisher_found_means_none_and_rclpy_publishes():
    class NotAServer:
        pass

    assert feedback_bytes(NotAServer(), 1024) is None
