"""QoS deadline, lifespan and liveliness of an rclpy publisher or subscription, wired to the node.

The timing is ``rclpy/_qos_timing.py``'s; here its watches are fed (message arrivals, publishes, Zenoh
liveliness) and polled by timers on the node's executor, so an event's callback runs where the entity's
other callbacks run: on the spinning thread, in the entity's callback group. An entity with none of these
policies gets no object at all (``None``), so publishing and delivery cost nothing more.
"""

from __future__ import annotations

import time
from typing import Any

from nodes.core.delivery import Executed
from nodes.core.liveliness import ManualAssertion, PublisherLiveliness, TopicPeers, Writer
from nodes.core.ros2 import names as ros2_names
from rclpy._qos_timing import (
    DeadlineWatch,
    LeaseWatch,
    LivelinessTracker,
    MatchedCounter,
    check_period,
    seconds,
)
from rclpy.event_handler import (
    QoSLivelinessChangedInfo,
    QoSLivelinessLostInfo,
    QoSOfferedDeadlineMissedInfo,
    QoSPublisherMatchedInfo,
    QoSRequestedDeadlineMissedInfo,
    QoSSubscriptionMatchedInfo,
)
from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy


def wire_qos(qos: QoSProfile) -> ros2_names.Qos:
    """The profile as the ROS 2 twin announces it in its liveliness token (what ``ros2 topic info -v`` of a
    ROS 2 machine shows)."""
    def ns(duration: Any) -> int:
        s = seconds(duration)
        return 0 if s is None else int(round(s * 1e9))

    return ros2_names.Qos(
        reliable=qos.reliability != ReliabilityPolicy.BEST_EFFORT,
        transient_local=qos.durability == DurabilityPolicy.TRANSIENT_LOCAL,
        depth=qos.depth if qos.depth > 0 else 42, keep_all=qos.history == HistoryPolicy.KEEP_ALL,
        deadline_ns=ns(qos.deadline), lifespan_ns=ns(qos.lifespan),
        liveliness=3 if qos.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC else 1,
        lease_ns=ns(qos.liveliness_lease_duration))


def _run(node: Any, callback: Any) -> Any:
    from rclpy._entities import _call_maybe_async

    return _call_maybe_async(node, callback)


class _Watches:
    """Timers on the node's executor, closed with the entity."""

    def __init__(self, node: Any, group: Any) -> None:
        self._node, self._group = node, group
        self._timers: list[Any] = []
        self._closers: list[Any] = []

    def every(self, period: float, fn: Any) -> None:
        timer = self._node._zr.create_timer(period, fn, sim_time=False)
        timer.group = self._group
        self._timers.append(timer)

    def poll_counts(self, watch: Any, period: float, callback: Any, info: Any) -> Any:
        """Poll ``watch`` (a deadline or a lease) on the executor; each new count reaches ``callback`` as
        ``info(total_count=, total_count_change=)``. Returns ``watch``."""
        on_change = _run(self._node, callback)

        def poll() -> None:
            counts = watch.poll(time.monotonic())
            if counts is not None:
                on_change(info(total_count=counts[0], total_count_change=counts[1]))

        self.every(check_period(period), poll)
        return watch

    def on_executor(self, fn: Any, where: str) -> None:
        self._node._zr.executor.put((fn, (), where, self._group))

    def watch_matches(self, kind: str, key: str, type_name: str, callback: Any, info: Any) -> None:
        """``callback(info(...))`` whenever the ``kind`` endpoints (``pub``/``sub``) this one matches change."""
        counter = MatchedCounter()
        on_matched = _run(self._node, callback)

        def report() -> None:
            counts = counter.report()
            if counts is not None:
                on_matched(info(total_count=counts[0], total_count_change=counts[1], current_count=counts[2],
                                current_count_change=counts[3]))

        def changed(peer: Writer, present: bool) -> None:   # a Zenoh thread
            counter.change(peer, present)
            self.on_executor(report, "matched")

        self._closers.append(TopicPeers(self._node._zr.session, kind, key, type_name, changed))

    def close(self) -> None:
        for timer in self._timers:
            timer.cancel()
        for closer in self._closers:
            closer.close()
        self._closers.clear()


class PublisherEvents(_Watches):
    def __init__(self, node: Any, key: str, type_name: str, qos: QoSProfile, callbacks: Any, group: Any) -> None:
        super().__init__(node, group)
        period, lease = seconds(qos.deadline), seconds(qos.liveliness_lease_duration)
        self._deadline: DeadlineWatch | None = None
        if period is not None and getattr(callbacks, "deadline", None) is not None:
            self._deadline = self.poll_counts(DeadlineWatch(period), period, callbacks.deadline,
                                              QoSOfferedDeadlineMissedInfo)
        self._manual: ManualAssertion | None = None
        self._lease: LeaseWatch | None = None
        if qos.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC:
            core = node._zr
            # a few assertions a lease reach the subscriptions, however often the program asserts
            self._manual = ManualAssertion(core.session, key, core.session_id, core.fully_qualified_name,
                                           lease / 4.0 if lease is not None else 1.0)
            self._closers.append(self._manual)
            if lease is not None and getattr(callbacks, "liveliness", None) is not None:
                self._lease = self.poll_counts(LeaseWatch(lease), lease, callbacks.liveliness,
                                               QoSLivelinessLostInfo)
        if getattr(callbacks, "matched", None) is not None:
            self.watch_matches("sub", key, type_name, callbacks.matched, QoSPublisherMatchedInfo)

    @classmethod
    def needed(cls, qos: QoSProfile, callbacks: Any) -> bool:
        return qos.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC or (
            seconds(qos.deadline) is not None and getattr(callbacks, "deadline", None) is not None) or (
            getattr(callbacks, "matched", None) is not None)

    def published(self) -> None:
        """A message went out: it meets the deadline and, as in DDS, asserts a manual publisher's liveliness."""
        now = time.monotonic()
        if self._deadline is not None:
            self._deadline.event(now)
        self.asserted(now)

    def asserted(self, now: float | None = None) -> None:
        if self._manual is None:
            return
        now = time.monotonic() if now is None else now
        self._manual.assert_liveliness(now)
        if self._lease is not None:
            self._lease.asserted(now)


class SubscriptionEvents(_Watches):
    def __init__(self, node: Any, key: str, type_name: str, qos: QoSProfile, callbacks: Any, group: Any) -> None:
        super().__init__(node, group)
        self.lifespan = seconds(qos.lifespan)
        period = seconds(qos.deadline)
        self._deadline: DeadlineWatch | None = None
        if period is not None and getattr(callbacks, "deadline", None) is not None:
            self._deadline = self.poll_counts(DeadlineWatch(period), period, callbacks.deadline,
                                              QoSRequestedDeadlineMissedInfo)
        if getattr(callbacks, "liveliness", None) is not None:
            lease = seconds(qos.liveliness_lease_duration)
            self._tracker = LivelinessTracker(lease)
            self._on_changed = _run(node, callbacks.liveliness)
            self._closers.append(PublisherLiveliness(node._zr.session, key, type_name, self._writer, self._manual,
                                                     self._asserted))
            if lease is not None:
                def expire() -> None:
                    self._tracker.expire(time.monotonic())
                    self._report()

                self.every(check_period(lease), expire)
        if getattr(callbacks, "matched", None) is not None:
            self.watch_matches("pub", key, type_name, callbacks.matched, QoSSubscriptionMatchedInfo)

    @classmethod
    def needed(cls, qos: QoSProfile, callbacks: Any) -> bool:
        return seconds(qos.lifespan) is not None or any(
            getattr(callbacks, name, None) is not None for name in ("deadline", "liveliness", "matched"))

    # -- Zenoh threads: the change is counted now, reported on the executor
    def _writer(self, writer: Writer, present: bool) -> None:
        self._tracker.writer(writer, present, time.monotonic())
        self.on_executor(self._report, "liveliness changed")

    def _manual(self, writer: Writer) -> None:
        self._tracker.manual(writer, time.monotonic())

    def _asserted(self, writer: Writer) -> None:
        self._tracker.asserted(writer, time.monotonic())
        self.on_executor(self._report, "liveliness changed")

    def _report(self) -> None:
        status = self._tracker.report()
        if status is not None:
            self._on_changed(QoSLivelinessChangedInfo(
                alive_count=status.alive_count, not_alive_count=status.not_alive_count,
                alive_count_change=status.alive_count_change, not_alive_count_change=status.not_alive_count_change))

    # -- delivery: each message stamped when it arrives (only when a deadline or a lifespan needs the time)
    @property
    def _stamps(self) -> bool:
        return self._deadline is not None or self.lifespan is not None

    def delivery(self, depth: int | None) -> Executed:
        return _Stamped(depth, self._arrived) if self._stamps else Executed(depth=depth)

    def _arrived(self, now: float) -> None:
        if self._deadline is not None:
            self._deadline.event(now)

    def callback(self, run: Any) -> Any:
        """The subscription's callback behind the stamp: a message older than the lifespan when its turn
        comes is dropped."""
        lifespan = self.lifespan
        if not self._stamps:
            return run
        if lifespan is None:
            return lambda _stamp, *args: run(*args)

        def take(stamp: float, *args: Any) -> None:
            if time.monotonic() - stamp <= lifespan:
                run(*args)

        return take


class _Stamped(Executed):
    """``Executed`` whose callback gets the monotonic time each message arrived first."""

    def __init__(self, depth: int | None, on_arrival: Any) -> None:
        super().__init__(depth)
        self._on_arrival = on_arrival

    def open(self, sub: Any) -> None:
        super().open(sub)
        run, run_in_process, on_arrival = self.run, self.run_in_process, self._on_arrival

        def stamped(*args: Any) -> None:
            now = time.monotonic()
            on_arrival(now)
            run(now, *args)

        def stamped_in_process(*args: Any) -> None:
            now = time.monotonic()
            on_arrival(now)
            run_in_process(now, *args)

        self.run = stamped   # type: ignore[method-assign]
        self.run_in_process = stamped_in_process   # type: ignore[method-assign]
