"""The timing of rclpy's QoS events (deadline, liveliness, lease) on a fake clock, and the QoS profile as the
ROS 2 wire spells it, read back by zenoh-ros2-sdk (an independent rmw_zenoh client)."""

from __future__ import annotations

import pytest


def test_deadline_counts_each_missed_period_from_the_first_event() -> None:
    from rclpy._qos_timing import DeadlineWatch

    watch = DeadlineWatch(0.5)
    assert watch.poll(10.0) is None            # nothing arrived yet: no instance, no deadline
    watch.event(10.0)
    assert watch.poll(10.49) is None
    assert watch.poll(10.5) == (1, 1)          # one whole period without a message
    assert watch.poll(10.9) is None            # the next period is not over yet
    assert watch.poll(11.75) == (3, 2)         # two more periods passed between two polls
    watch.event(11.8)                          # a message: the deadline starts again from it
    assert watch.poll(12.2) is None
    assert watch.poll(12.3) == (4, 1)
    with pytest.raises(ValueError, match="deadline period must be > 0"):
        DeadlineWatch(0.0)


def test_a_manual_publishers_lease_is_lost_once_per_lapse() -> None:
    from rclpy._qos_timing import LeaseWatch

    lease = LeaseWatch(1.0)
    assert lease.poll(5.0) is None             # never asserted: nothing to lose yet
    lease.asserted(5.0)
    assert lease.poll(5.9) is None
    assert lease.poll(6.1) == (1, 1)
    assert lease.poll(9.0) is None             # still lost: reported once
    lease.asserted(9.0)
    assert lease.poll(10.5) == (2, 1)


def test_liveliness_counts_publishers_that_come_go_and_stop_asserting() -> None:
    from rclpy._qos_timing import LivelinessStatus, LivelinessTracker

    tracker = LivelinessTracker(lease=1.0)
    assert tracker.report() is None
    tracker.writer(("s1", "/talker"), True, 0.0)
    tracker.writer(("s2", "/manual"), True, 0.0)
    tracker.manual(("s2", "/manual"), 0.0)
    assert tracker.report() == LivelinessStatus(2, 0, 2, 0)
    assert tracker.report() is None            # no change, no event
    tracker.asserted(("s2", "/manual"), 0.8)
    tracker.expire(1.5)                        # the automatic one needs no assertion
    assert tracker.report() is None
    tracker.expire(1.9)                        # the manual one last asserted 1.1 s ago
    assert tracker.report() == LivelinessStatus(1, 1, -1, 1)
    tracker.asserted(("s2", "/manual"), 2.0)
    assert tracker.report() == LivelinessStatus(2, 0, 1, -1)
    tracker.writer(("s1", "/talker"), False, 2.5)   # its token went: destroyed or killed
    assert tracker.report() == LivelinessStatus(1, 1, -1, 1)
    tracker.asserted(("s1", "/talker"), 2.6)   # an assertion without its token does not revive it
    assert tracker.report() is None
    tracker.writer(("s1", "/talker"), True, 3.0)    # the same node's publisher made again
    assert tracker.report() == LivelinessStatus(2, 0, 1, -1)


def test_liveliness_without_a_lease_never_expires() -> None:
    from rclpy._qos_timing import LivelinessTracker

    tracker = LivelinessTracker(lease=None)
    tracker.manual(("s", "/n"), 0.0)
    tracker.writer(("s", "/n"), True, 0.0)
    tracker.report()
    tracker.expire(1e6)
    assert tracker.report() is None


def test_qos_durations_and_poll_periods() -> None:
    from rclpy._qos_timing import check_period, seconds
    from rclpy.duration import Duration, Infinite

    assert seconds(Duration()) is None and seconds(Infinite) is None
    assert seconds(Duration(seconds=0.25)) == 0.25
    assert check_period(0.2) == 0.05 and check_period(10.0) == 0.1 and check_period(0.001) == 0.002


def test_the_profile_on_the_ros2_wire_is_what_zenoh_ros2_sdk_reads() -> None:
    from zenoh_ros2_sdk.qos import QosProfile

    from nodes.core.ros2.names import Qos
    from rclpy._graph_info import profile_of
    from rclpy._qos_events import wire_qos
    from rclpy.duration import Duration, Infinite
    from rclpy.qos import LivelinessPolicy, QoSProfile, ReliabilityPolicy

    profile = QoSProfile(depth=7, reliability=ReliabilityPolicy.BEST_EFFORT, deadline=Duration(seconds=0.25),
                         lifespan=Duration(seconds=2), liveliness=LivelinessPolicy.MANUAL_BY_TOPIC,
                         liveliness_lease_duration=Duration(seconds=1.5))
    token = wire_qos(profile).token()
    seen = QosProfile.decode(token)
    assert (seen.reliability.name, seen.history_depth, seen.liveliness.name) == ("BEST_EFFORT", 7, "MANUAL_BY_TOPIC")
    assert (seen.deadline.sec, seen.deadline.nsec) == (0, 250_000_000)
    assert (seen.lifespan.sec, seen.lifespan.nsec) == (2, 0)
    assert (seen.liveliness_lease_duration.sec, seen.liveliness_lease_duration.nsec) == (1, 500_000_000)
    back = profile_of(Qos.parse(token))
    assert back.deadline == Duration(seconds=0.25) and back.lifespan == Duration(seconds=2)
    assert back.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC and back.depth == 7
    # the defaults stay what rmw_zenoh writes for them (empty fields), read back as infinite
    assert Qos().token() == "::,10:,:,:,,"
    assert profile_of(Qos.parse(QosProfile().encode())).deadline == Infinite
    with pytest.raises(ValueError, match="not an rmw_zenoh QoS"):
        Qos.parse("1:2")


def test_matched_counts_peers_now_and_ever() -> None:
    from rclpy._qos_timing import MatchedCounter

    counter = MatchedCounter()
    assert counter.report() is None
    counter.change("a", True)
    counter.change("a", True)                  # the same peer seen twice (history, then live): one match
    counter.change("b", True)
    assert counter.report() == (2, 2, 2, 2)
    counter.change("a", False)
    assert counter.report() == (2, 0, 1, -1)
    counter.change("a", True)                  # back: a new match
    assert counter.report() == (3, 1, 2, 1)
    counter.change("c", False)                 # never matched: nothing changes
    assert counter.report() is None


def test_liveliness_forgets_the_oldest_of_many_gone_publishers() -> None:
    from rclpy._qos_timing import LivelinessTracker

    tracker = LivelinessTracker(lease=None)
    tracker.MAX_GONE = 3
    for i in range(5):
        tracker.writer(("s", f"/p{i}"), True, float(i))
        tracker.writer(("s", f"/p{i}"), False, float(i) + 0.5)
    tracker.writer(("s", "/alive"), True, 9.0)
    status = tracker.report()
    assert (status.alive_count, status.not_alive_count) == (1, 3)
    tracker.writer(("s", "/p4"), True, 10.0)   # the latest gone, back: still known, alive again
    assert tracker.report().not_alive_count == 2
