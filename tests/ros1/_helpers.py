"""Waiting on a runner process and on messages, for the ROS 1 tests."""

import time

import rospy

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

    def close(self):
        for t in self._topics:
            t.unregister()


class Received(list):
    sub = None

    def connected(self, timeout=10.0):
        """Wait until the subscriber is connected to a publisher."""
        return wait_until(lambda: self.sub.get_num_connections() > 0, timeout)
