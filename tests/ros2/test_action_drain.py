"""The bridge's drain of an action's events (rtcf._ros2._actions), in this process: no
rtcf process to start; the loop's side is written by hand on rings of this process."""

from __future__ import annotations

from test_msgs.action import Fibonacci

from ._action_client import action_client


def _ring(direction):
    from rtcf._core._rings import Ring
    from rtcf._runtime import _action_channels as ac

    records, size = ac.ring_shape(direction, 4096)
    return Ring.create(bytearray(Ring.nbytes(records, size)), records, size)


def _feedback(goal_id, n):
    from rtcf import ActionEvent

    return ActionEvent(ActionEvent.FEEDBACK, goal_id, 2, Fibonacci.Feedback(sequence=range(n)))


def test_the_drain_publishes_feedback_in_order_early_ones_at_the_accept(ros_node):
    """Feedback written before rclpy's accept goes out at the accept, before the later
    ones."""
    from rclpy.executors import SingleThreadedExecutor

    from rtcf import ActionEvent
    from rtcf._ros2._actions import ActionBridge, _Served
    from rtcf._runtime import _action_channels as ac

    executor = SingleThreadedExecutor(context=ros_node.context)
    bridge = ActionBridge(ros_node, executor, lambda component: True)
    served = _Served(ros_node, Fibonacci, "/drained", "/c", bridge)
    bridge._served["/drained"] = served
    served.requests, served.events = _ring(ac.REQUESTS), _ring(ac.EVENTS)
    tap = ac.EventTap(served.events, ac.message_codecs("/drained", Fibonacci), [0])
    with action_client(ros_node, Fibonacci, "/drained") as client:
        got = []
        future = client.send_goal_async(
            Fibonacci.Goal(order=3), feedback_callback=lambda m: got.append(m.feedback))
        assert client.until(lambda: served.requests.pending()[1] == 1)
        goal_id = next(iter(served.goals))
        # the request carries the client's goal UUID (ActionRequest.uuid in the loop)
        slot, _ = served.requests.pending()
        uuid = ac._REQUEST.unpack_from(served.requests.data, slot * served.requests.record_size)[4]
        sent = next(iter(client._goal_sequence_number_to_goal_id.values()))
        assert uuid == bytes(sent.uuid) != bytes(16)
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
        bridge.close_run()
        assert client.until(lambda: served.goals == {})
    bridge.shutdown()
