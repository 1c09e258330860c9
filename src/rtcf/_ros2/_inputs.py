"""Mapped inputs taken from DDS by a thread of their own, without rclpy's executor.

rclpy's executor rebuilds its wait set in Python from every entity of every node it
spins, each time it waits: the runner's node and each component's node, with their
parameter, logger and lifecycle services, some sixty entities. Taking one message
that way costs about a millisecond of the supervisor's CPU, and the message waits
for the executor's other work. Here the subscriptions of the mapped inputs are made on
the runner's node (the graph shows them as its own, as before) but are not registered
with the node, so no executor sees them: one thread waits on a wait set that holds only
them, takes each message as bytes (raw) and hands the bytes to the run's mailbox. It
runs at the publishing thread's SCHED_FIFO priority, on the supervisor's CPU.

This uses the layer under rclpy's Node and Executor (``rclpy_implementation``: the
``Subscription``, ``WaitSet`` and ``GuardCondition`` that those are made of), as
rclpy's own executors do.

An input with a deadline is taken here too, with its subscription's QoS events
(matched, liveliness, deadline missed, incompatible QoS: rclpy's
``SubscriptionEventCallbacks``, made into rclpy's event handlers). This thread waits
on the events beside the data and takes each (one call into rcl), but does not run
their callbacks: it queues them and wakes rclpy's executor (a guard condition on the
node), which runs them. They log, publish on /rosout and ask the graph how many
publishers there are: work that has no place on a SCHED_FIFO thread whose one job is
to hand data over at once, and that may wait (on a slow console, say); events are
rare and the loop's own deadline decides, so they may wait for the executor. The
events are not left to the executor's wait set: with Fast DDS an event of a
subscription wakes a wait set whenever the subscription holds data not taken yet, so
an executor waiting on them spins until this thread has taken each message (measured:
8 to 10 % more of a core for 200 messages/s).
"""

from __future__ import annotations

import contextlib
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

WAIT_NS = 50_000_000  # how often the thread looks whether to end, at the latest


class DirectInputs:
    """The mapped inputs' subscriptions of one node, and the thread that takes them."""

    def __init__(self, node: Any, scheduling: Callable[[], object] | None = None) -> None:
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        self._rclpy = _rclpy
        self._node = node
        self._context = node.context
        self._lock = threading.Lock()
        # (subscription handle, message class, callback taking the raw bytes)
        self._subs: list[tuple[Any, type, Callable[[bytes], None]]] = []
        self._handlers: list[Any] = []  # the subscriptions' event handlers (rclpy's)
        # events taken here, with their callbacks, for the executor to run
        self._events: deque[tuple[Callable[[Any], None], Any]] = deque()
        self._run_events = node.create_guard_condition(self._serve_events)
        self._generation = 0
        with self._context.handle:
            self._wake = _rclpy.GuardCondition(self._context.handle)
        self._scheduling = scheduling  # applied first thing in the thread
        self._running = True
        self._thread = threading.Thread(target=self._take, name="rtcf-ros2-take", daemon=True)
        self._thread.start()

    def add(
        self, cls: type, topic: str, qos: Any, on_bytes: Callable[[bytes], None],
        events: Any = None,
    ) -> None:
        """Subscribe ``topic`` (raw) on the node; each message's bytes go to ``on_bytes``,
        and its QoS events to ``events`` (a ``SubscriptionEventCallbacks``), run by
        rclpy's executor."""
        from rclpy.type_support import check_is_valid_msg_type

        check_is_valid_msg_type(cls)
        with self._node.handle:
            handle = self._rclpy.Subscription(
                self._node.handle, cls, topic, qos.get_c_qos_profile()
            )
        handlers = [] if events is None else events.create_event_handlers(
            self._node.default_callback_group, handle, topic
        )
        with self._lock:
            self._subs.append((handle, cls, on_bytes))
            self._handlers += handlers
            self._generation += 1
        self._wake.trigger_guard_condition()

    def clear(self) -> None:
        """Unsubscribe all (destroyed once the thread no longer waits on them)."""
        with self._lock:
            subs, self._subs = self._subs, []
            handlers, self._handlers = self._handlers, []
            self._generation += 1
        self._wake.trigger_guard_condition()
        for handler in handlers:  # before their subscription: they point into it
            handler.destroy()
        for handle, _, _ in subs:
            handle.destroy_when_not_in_use()

    def close(self) -> None:
        self._running = False
        with contextlib.suppress(Exception):
            self._wake.trigger_guard_condition()
        self._thread.join(timeout=5.0)
        self.clear()
        self._wake.destroy_when_not_in_use()
        self._node.destroy_guard_condition(self._run_events)

    def _serve_events(self) -> None:
        """The queued events' callbacks (in rclpy's executor)."""
        while self._events:
            callback, info = self._events.popleft()
            callback(info)

    def _take(self) -> None:
        from rclpy.exceptions import InvalidHandle

        if self._scheduling is not None:
            self._scheduling()
        rclpy = self._rclpy
        generation = -1
        subs: list[tuple[Any, type, Callable[[bytes], None]]] = []
        handlers: list[Any] = []
        wait_set = None
        while self._running:
            with self._lock:
                if generation != self._generation:
                    generation, subs = self._generation, list(self._subs)
                    handlers = list(self._handlers)
                    wait_set = None
            try:
                with contextlib.ExitStack() as stack:
                    stack.enter_context(self._context.handle)
                    for handle, _, _ in subs:
                        stack.enter_context(handle)
                    for handler in handlers:
                        stack.enter_context(handler)
                    stack.enter_context(self._wake)
                    if wait_set is None:
                        wait_set = rclpy.WaitSet(
                            len(subs), 1, 0, 0, 0, len(handlers), self._context.handle
                        )
                    wait_set.clear_entities()
                    for handle, _, _ in subs:
                        wait_set.add_subscription(handle)
                    for handler in handlers:
                        handler.add_to_wait_set(wait_set)
                    wait_set.add_guard_condition(self._wake)
                    wait_set.wait(WAIT_NS)
                    ready = wait_set.get_ready_entities("subscription")
                    for handle, cls, on_bytes in subs:
                        if handle.pointer not in ready:
                            continue
                        while (taken := handle.take_message(cls, True)) is not None:
                            on_bytes(taken[0])
                    if handlers:
                        self._take_events(handlers, wait_set)
            except InvalidHandle:  # destroyed meanwhile (a run closed): look again
                generation = -1
            except Exception:
                if not self._running or not self._context.ok():  # shutting down
                    return
                raise

    def _take_events(self, handlers: list[Any], wait_set: Any) -> None:
        """Take the events that are ready; queue them for the executor."""
        taken = False
        for handler in handlers:
            if handler.is_ready(wait_set) and (info := handler.take_data()) is not None:
                self._events.append((handler.callback, info))
                taken = True
        if taken:
            self._run_events.trigger()
