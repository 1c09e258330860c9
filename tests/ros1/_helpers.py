"""Waiting on a runner process and on messages, for the ROS 1 tests."""

import time

import rospy
from std_msgs.msg import Float64

from .. import _proc


def wait_running(proc, timeout=30.0):
    return _proc.wait_running(proc, timeout, "running")


def stop(proc):
    """SIGINT, as Ctrl-C would: the loop ends, the components clean up, exit 0."""
    out, err = _proc.stop(proc)
    assert "stopped after" in err, err
    return out, err


def wait_until(predicate, timeout=10.0, publish=None, every=0.05):
    """Poll ``predicate`` (publishing with ``publish`` meanwhile); True once it holds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if publish is not None:
            publish()
        if predicate():
            return True
        time.sleep(every)
    return predicate()


class Topics:
    """Publishers and subscribers of this test process, unregistered after the test."""

    def __init__(self):
        self._topics = []

    def sub(self, topic, cls, queue_size=100):
        """The list of messages received on ``topic`` (its ``sub`` is the subscriber)."""
        got = Received()
        got.sub = rospy.Subscriber(topic, cls, got.append, queue_size=queue_size)
        self._topics.append(got.sub)
        return got

    def pub(self, topic, cls, **kwargs):
        pub = rospy.Publisher(topic, cls, queue_size=kwargs.pop("queue_size", 10), **kwargs)
        self._topics.append(pub)
        return pub

    def float_probe(self, topic_in, topic_out, x):
        """A Float64 ``x`` to publish on a component's mapped input, and what its mapped
        output sends back (connected before it returns)."""
        out = self.sub(topic_out, Float64)
        pub = self.pub(topic_in, Float64)
        assert out.connected(), f"nothing publishes {topic_out}"
        return FloatProbe(out, lambda: pub.publish(Float64(x)))

    def close(self):
        for t in self._topics:
            t.unregister()


class FloatProbe:
    """Float64 messages received (``out``) while ``feed`` publishes one input value."""

    def __init__(self, out, feed):
        self.out = out
        self._feed = feed

    def answers(self, expected):
        """Feed until the last value received equals ``expected``; False if it did not
        within wait_until's timeout."""
        return wait_until(lambda: self.out and self.out[-1].data == expected, publish=self._feed)


class Received(list):
    sub = None

    def connected(self, timeout=10.0):
        """Wait until the subscriber is connected to a publisher."""
        return wait_until(lambda: self.sub.get_num_connections() > 0, timeout)
