"""rclpy's QoS events, lifespan and graph info on zenroid: ROS 2 Python programs (tests/support/rclpy_programs)
as real processes over real Zenoh, the QoS they announce read by zenoh-ros2-sdk (an independent rmw_zenoh
client), and the parts a test can drive more tightly from an rclpy context of this process."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import shim_env

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"
PEER = ROOT / "tests" / "support" / "ros2_peer.py"


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    from bench.common import child_env

    return shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])


def peer_info(zenoh_port: int, topic: str) -> list[dict]:
    """What zenoh-ros2-sdk lists for ``topic`` (``ros2 topic info -v``), one dict per endpoint."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}
    done = subprocess.run([sys.executable, str(PEER), "info", str(zenoh_port), topic], capture_output=True,
                          text=True, timeout=60, env=env, cwd=PEER.parent)
    assert done.returncode == 0, done.stdout + done.stderr
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def totals(what: str, log: str, *, with_change: bool = False) -> list:
    """The totals (and changes) of the ``what - total N (delta D)`` lines of a log, in order."""
    found = [(int(m.group(1)), int(m.group(2))) for m in re.finditer(re.escape(what) + r" - total (\d+) \(delta (\d+)\)",
                                                                   log)]
    return found if with_change else [total for total, _ in found]


def spin_for(executor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=max(0.0, min(0.05, end - time.monotonic())))


@pytest.mark.slow
def test_deadline_liveliness_and_lifespan_between_programs(processes, zenoh_port, ros_env, context) -> None:
    """A talker that falls silent: both sides' deadline callbacks count the missed periods; its manual
    liveliness lapses (the listener sees it not alive, the talker its liveliness lost); killed, its automatic
    publisher turns not alive. Its transient-local status reaches a late joiner only within its lifespan.
    zenoh-ros2-sdk, ``get_publishers_info_by_topic`` and ``zenroid topic info -v`` see the profiles it
    announces."""
    from std_msgs.msg import String

    import rclpy
    from rclpy.duration import Duration
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, LivelinessPolicy, QoSProfile
    from rclpy.topic_endpoint_info import TopicEndpointTypeEnum

    listener = processes.start(str(PROGRAMS / "qos_listener.py"), name="listener", env=ros_env)
    wait_until(lambda: "connected to" in processes.output(listener), timeout=30,
               message="the listener up\n" + processes.output(listener)[-1500:])
    talker = processes.start(str(PROGRAMS / "qos_talker.py"), "5", "3.0", name="talker", env=ros_env)
    wait_until(lambda: "Published status" in processes.output(talker), timeout=30,
               message="the talker up\n" + processes.output(talker)[-1500:])
    published = time.monotonic()

    # a late joiner within the status' lifespan gets it, fetched from the talker's cache
    node = rclpy.create_node("qos_probe", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    early: list[str] = []
    node.create_subscription(String, "/status", lambda m: early.append(m.data), latched)
    while not early and time.monotonic() < published + 2.5:
        executor.spin_once(timeout_sec=0.05)
    assert early == ["ready"], "a late joiner within the lifespan must get the status"

    out = lambda p: processes.output(p)  # noqa: E731
    wait_until(lambda: totals("Requested deadline missed", out(listener))[-1:] >= [2], timeout=20,
               message="the listener's deadline callback\n" + out(listener)[-2000:])
    wait_until(lambda: totals("Offered deadline missed", out(talker))[-1:] >= [2], timeout=20,
               message="the talker's deadline callback\n" + out(talker)[-2000:])
    for side in (listener, talker):   # each event counts what it adds to the total
        counts = totals("deadline missed", out(side), with_change=True)
        assert all(total == before + change for (before, _), (total, change) in zip([(0, 0), *counts], counts)), \
            counts
    heard = [line for line in out(listener).splitlines() if "I heard" in line]
    assert len(heard) == 5, heard
    assert "]: heartbeat liveliness changed - alive 1 (delta 1), not alive 0 (delta 0)" in out(listener)
    wait_until(lambda: "manual_heartbeat liveliness changed - alive 0 (delta -1), not alive 1 (delta 1)"
               in out(listener), timeout=20, message="the manual publisher's lease lapsing\n" + out(listener)[-2000:])
    wait_until(lambda: "Liveliness lost - total 1 (delta 1)" in out(talker), timeout=20,
               message="the talker's liveliness lost\n" + out(talker)[-2000:])

    # the profiles, as this rclpy and a ROS 2 machine (zenoh-ros2-sdk) list them
    infos = node.get_publishers_info_by_topic("/heartbeat")
    assert [(i.node_name, i.node_namespace, i.topic_type, i.endpoint_type) for i in infos] == [
        ("qos_talker", "/", "std_msgs/msg/String", TopicEndpointTypeEnum.PUBLISHER)]
    assert infos[0].qos_profile.deadline == Duration(seconds=0.3)
    assert infos[0].qos_profile.liveliness_lease_duration == Duration(seconds=1.0)
    assert len(infos[0].endpoint_gid) == 16
    subs = node.get_subscriptions_info_by_topic("/manual_heartbeat")
    assert [(i.node_name, i.qos_profile.liveliness) for i in subs] == [
        ("qos_listener", LivelinessPolicy.MANUAL_BY_TOPIC)]
    def both_sides() -> list[dict]:   # a fresh session's first liveliness answer may be partial: ask again
        seen = peer_info(zenoh_port, "/heartbeat")
        return seen if {e["kind"] for e in seen} == {"publisher", "subscription"} else []

    seen = wait_until(both_sides, timeout=30, interval=0.5, message="zenoh-ros2-sdk listing /heartbeat")
    by_kind = {e["kind"]: e for e in seen}
    assert by_kind["publisher"]["node"] == "qos_talker", seen
    assert by_kind["publisher"]["qos"]["deadline"] == [0, 300_000_000], seen
    assert by_kind["publisher"]["qos"]["lease"] == [1, 0], seen
    assert by_kind["subscription"]["node"] == "qos_listener", seen
    cli = subprocess.run([sys.executable, "-m", "nodes.tools.cli", "topic", "info", "-v", "heartbeat"],
                         capture_output=True, text=True, env=processes.env(), cwd=ROOT, timeout=60)
    assert cli.returncode == 0, cli.stdout + cli.stderr
    assert "Publisher count: 1\n\nNode name: qos_talker\n" in cli.stdout, cli.stdout   # ros2 topic info -v
    assert "  Deadline: 300000000 nanoseconds\n  Liveliness: AUTOMATIC\n" in cli.stdout, cli.stdout

    # past its lifespan, the status is not given to a late joiner any more
    time.sleep(max(0.0, published + 3.3 - time.monotonic()))
    late: list[str] = []
    node.create_subscription(String, "/status", lambda m: late.append(m.data), latched)
    spin_for(executor, 2.5)
    assert late == [], "the status outlived its lifespan"

    talker.kill()   # no goodbye: the router drops the dead session's tokens
    talker.wait(timeout=10)
    wait_until(lambda: "]: heartbeat liveliness changed - alive 0 (delta -1), not alive 1 (delta 1)"
               in out(listener), timeout=20, message="the killed talker not alive\n" + out(listener)[-2000:])


def test_a_subscription_drops_what_waited_longer_than_its_lifespan(context) -> None:
    """Messages that waited for the spinning thread longer than the subscription's lifespan are dropped."""
    from std_msgs.msg import String

    import rclpy
    from rclpy.duration import Duration
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile

    node = rclpy.create_node("lifespan_probe", context=context)
    got: list[str] = []
    node.create_subscription(String, "/fresh", lambda m: got.append(m.data),
                             QoSProfile(depth=10, lifespan=Duration(seconds=0.3)))
    publisher = node.create_publisher(String, "/fresh", 10)
    wait_until(lambda: publisher.get_subscription_count() >= 1, timeout=10, message="the subscription")
    for text in ("stale 1", "stale 2"):
        publisher.publish(String(data=text))
    time.sleep(0.6)   # nobody spins: they wait
    publisher.publish(String(data="fresh"))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    end = time.monotonic() + 5
    while "fresh" not in got and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    assert got == ["fresh"]


def test_deadline_liveliness_and_matched_callbacks_run_on_the_executor(context) -> None:
    """The deadline, liveliness and matched callbacks run on the spinning thread (the entity's callback
    group), a coroutine callback as a task; a publisher destroyed goes not alive and unmatched;
    assert_liveliness keeps a manual publisher alive without publishing."""
    import threading

    from std_msgs.msg import String

    import rclpy
    from rclpy.duration import Duration
    from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import LivelinessPolicy, QoSProfile

    node = rclpy.create_node("events_probe", context=context)
    manual = QoSProfile(depth=5, deadline=Duration(seconds=0.2), liveliness=LivelinessPolicy.MANUAL_BY_TOPIC,
                        liveliness_lease_duration=Duration(seconds=0.4))
    events: list[tuple[str, object, str]] = []

    async def on_deadline(info):
        events.append(("deadline", info, threading.current_thread().name))

    def record(kind):
        return lambda info: events.append((kind, info, threading.current_thread().name))

    node.create_subscription(String, "/beat", lambda m: None, manual, event_callbacks=SubscriptionEventCallbacks(
        deadline=on_deadline, liveliness=record("liveliness"), matched=record("sub matched")))
    lost: list[object] = []
    publisher = node.create_publisher(String, "/beat", manual, event_callbacks=PublisherEventCallbacks(
        liveliness=lost.append, matched=record("pub matched")))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    me = threading.current_thread().name
    publisher.publish(String(data="one"))
    end = time.monotonic() + 1.2
    while time.monotonic() < end:   # asserting by hand, more often than the lease, without publishing
        publisher.assert_liveliness()
        executor.spin_once(timeout_sec=0.05)
    changes = [info for kind, info, _ in events if kind == "liveliness"]
    assert changes and changes[-1].alive_count == 1 and changes[-1].not_alive_count == 0, changes
    assert lost == []
    deadlines = [info for kind, info, _ in events if kind == "deadline"]
    assert deadlines and deadlines[-1].total_count >= 4, deadlines
    assert {thread for _, _, thread in events} == {me}
    for kind in ("sub matched", "pub matched"):
        matched = [info for k, info, _ in events if k == kind]
        assert [(m.total_count, m.current_count) for m in matched] == [(1, 1)], (kind, matched)
    assert publisher.wait_for_all_acked(Duration(seconds=1)) is True   # as rmw_zenoh: nothing to wait for
    node.destroy_publisher(publisher)
    wait_until(lambda: executor.spin_once(timeout_sec=0.05) or [
        i for k, i, _ in events if k == "liveliness" and i.alive_count == 0 and i.not_alive_count == 1],
        timeout=10, message=f"the destroyed publisher not alive: {events}")
    wait_until(lambda: executor.spin_once(timeout_sec=0.05) or [
        i for k, i, _ in events if k == "sub matched" and (i.total_count, i.current_count, i.current_count_change)
        == (1, 0, -1)], timeout=10, message=f"the destroyed publisher unmatched: {events}")


@pytest.mark.slow
def test_a_ros2_publisher_matches_and_goes_not_alive(context, zenoh_port) -> None:
    """A ROS 2 node's publisher (zenoh-ros2-sdk: its rmw_zenoh token, no zenroid graph token) is matched and
    alive while it runs, not alive and unmatched once its process ends; its messages arrive."""
    from std_msgs.msg import String

    import rclpy
    from msgs.type_hash import rihs01
    from rclpy.event_handler import SubscriptionEventCallbacks
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile

    node = rclpy.create_node("ros2_watcher", context=context)
    events: list[tuple[str, object]] = []
    heard: list[str] = []
    node.create_subscription(String, "/ros2_chatter", lambda m: heard.append(m.data), QoSProfile(depth=10),
                             event_callbacks=SubscriptionEventCallbacks(
                                 liveliness=lambda i: events.append(("liveliness", i)),
                                 matched=lambda i: events.append(("matched", i))))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}
    talker = subprocess.Popen([sys.executable, str(PEER), "talk", str(zenoh_port), "/ros2_chatter",
                               "std_msgs/msg/String", "string data\n", rihs01("std_msgs/msg/String"),
                               json.dumps({"data": "from ROS 2"}), "2"], env=env, cwd=PEER.parent,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 60
        while talker.poll() is None and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        assert talker.returncode == 0, talker.communicate()[1][-2000:]
        spin_for(executor, 1.0)   # its tokens leave with its session
    finally:
        if talker.poll() is None:
            talker.kill()
    assert "from ROS 2" in heard
    liveliness = [(i.alive_count, i.not_alive_count) for k, i in events if k == "liveliness"]
    matched = [(i.total_count, i.current_count) for k, i in events if k == "matched"]
    assert liveliness == [(1, 0), (0, 1)], events
    assert matched == [(1, 1), (1, 0)], events
