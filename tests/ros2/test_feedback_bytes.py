"""An action's feedback published from CDR bytes through rclpy's action server's own
publisher (rtcf._ros2._feedback_bytes), in this process: no rtcf process to start."""

from __future__ import annotations

import pytest
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


def _ring(direction):
    from rtcf._core._rings import Ring
    from rtcf._runtime import _action_channels as ac

    records, size = ac.ring_shape(direction, 4096)
    return Ring.create(bytearray(Ring.nbytes(records, size)), records, size)


def _feedback(goal_id, n):
    from rtcf import ActionEvent

    return ActionEvent(ActionEvent.FEEDBACK, goal_id, 2, Fibonacci.Feedback(sequence=range(n)))


@pytest.mark.parametrize("as_bytes", [True, False], ids=["bytes", "decoded"])
def test_the_drain_publishes_feedback_in_order_early_ones_at_the_accept(ros_node, as_bytes):
    """The bridge's drain on rings of this process, the loop's side written by hand:
    feedback written before rclpy's accept goes out at the accept, before the later
    ones; as bytes, or decoded for rclpy where no byte publisher was found."""
    from rclpy.executors import SingleThreadedExecutor

    from rtcf import ActionEvent
    from rtcf._ros2._actions import ActionBridge, _Served
    from rtcf._runtime import _action_channels as ac

    executor = SingleThreadedExecutor(context=ros_node.context)
    bridge = ActionBridge(ros_node, executor, lambda component: True)
    served = _Served(ros_node, Fibonacci, "/drained", "/c", bridge)
    bridge._served["/drained"] = served
    served.requests, served.events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    assert served.feedback_bytes is not None
    if not as_bytes:
        served.feedback_bytes = None
    tap = ac.EventTap(served.events, ac.message_codecs("/drained", Fibonacci), [0])
    with action_client(ros_node, Fibonacci, "/drained") as client:
        got = []
        future = client.send_goal_async(
            Fibonacci.Goal(order=3), feedback_callback=lambda m: got.append(m.feedback))
        assert client.until(lambda: served.requests.pending()[1] == 1)
        goal_id = next(iter(served.goals))
        tap(ActionEvent(ActionEvent.RESPONSE, goal_id, 2, None, 1))  # accepted...
        for n in (1, 2):  # ... and fed back before rclpy's accept
            tap(_feedback(goal_id, n))
        bridge.drain()
        assert served.goals[goal_id].early  # no handle yet: kept for the accept
        assert client.wait(future).accepted
        for n in (3, 4):
            tap(_feedback(goal_id, n))
        bridge.drain()
        assert client.until(lambda: len(got) == 4)
        assert [list(f.sequence) for f in got] == [list(range(n)) for n in (1, 2, 3, 4)]
        if as_bytes:  # every one went out as bytes, none through rclpy's decoding
            assert served.feedback_bytes.published == 4
        bridge.close_run()
        assert client.until(lambda: served.goals == {})
    bridge.shutdown()
