"""In-process hand-off between nodes sharing a container's session (nodes/core/intraprocess.py), over a real
router: a subscriber in the same session gets the published object itself, once; a node on another session
(standing in for another process) gets the same message over Zenoh, once; raw bytes stay the same bytes; a
pulled subscription's blocked wait wakes for an in-process message; both nodes are on the graph."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

import msgs
from msgs.sensor_msgs import JointState
from nodes.core import Node, graph, intraprocess
from nodes.core.delivery import Inline, Pulled, Raw
from nodes.core.session import open_peer
from tests.conftest import wait_until


@pytest.fixture
def container_session(router: str) -> Iterator[object]:
    session = open_peer([router])
    intraprocess.enable(session)
    yield session
    intraprocess.disable(session)
    session.close()


def state(position: float) -> JointState:
    return JointState(name=["a"], position=[position], velocity=[0.0], effort=[0.0])


def test_a_message_reaches_its_own_session_in_process_and_other_sessions_over_zenoh(router: str,
                                                                                    container_session: object) -> None:
    talker = Node("talker", session=container_session)
    listener = Node("listener", session=container_session)
    outside = Node("outside", connect=[router])   # another session: what another process sees
    try:
        local: list[object] = []
        local_raw: list[bytes] = []
        remote: list[JointState] = []
        listener.create_subscription(JointState, "joint_states", local.append)
        listener.create_subscription(JointState, "joint_states", local_raw.append, message=Raw())
        outside.create_subscription(JointState, "joint_states", remote.append)
        pub = talker.create_publisher(JointState, "joint_states")
        # until the remote subscription is known here (declarations travel asynchronously)
        wait_until(lambda: pub.publish(state(-1.0)) or remote, 10, message="the remote subscriber matched")
        time.sleep(0.2)
        local.clear()
        local_raw.clear()
        remote.clear()
        sent = [state(float(i)) for i in range(20)]
        for msg in sent:
            pub.publish(msg)
        wait_until(lambda: len(remote) >= len(sent), 10, message="every message over Zenoh")
        time.sleep(0.3)   # a second copy would have arrived by now
        assert len(local) == len(sent) and all(got is msg for got, msg in zip(local, sent, strict=True)), \
            "the same session gets the published objects themselves, once each"
        assert len(local_raw) == len(sent) and all(isinstance(b, bytes) for b in local_raw)
        assert len(remote) == len(sent) and [m.position for m in remote] == [m.position for m in sent]

        # publish_raw: the bytes object itself to a raw subscriber, decoded for a typed one
        payload = local_raw[0]
        local.clear()
        local_raw.clear()
        pub.publish_raw(payload)
        wait_until(lambda: len(remote) > len(sent), 10, message="the raw message over Zenoh")
        assert local_raw == [payload] and local_raw[0] is payload
        assert len(local) == 1 and local[0].position == [0.0]

        # both nodes are on the graph, as separate processes' nodes are
        assert {"/talker", "/listener"} <= set(graph.node_names(outside.session, timeout=2.0))
    finally:
        for node in (talker, listener, outside):
            node.destroy()


def test_a_raw_subscription_taking_objects_gets_the_object_in_process_and_bytes_from_outside(
        router: str, container_session: object) -> None:
    """``objects=True`` (the composed simulator's and controller manager's hardware frames): a message published
    as an object by a node of the same process arrives as that object, neither encoded nor decoded; raw bytes
    published in-process, and everything from another process, arrive as bytes to check as usual."""
    talker = Node("talker", session=container_session)
    listener = Node("listener", session=container_session)
    outside = Node("outside", connect=[router])
    try:
        got: list[object] = []
        listener.create_subscription(JointState, "frames", got.append,
                                     delivery=Inline(), message=Raw(objects=True))
        pub = talker.create_publisher(JointState, "frames")
        msg = state(1.5)
        pub.publish(msg)
        assert got == [msg] and got[0] is msg
        pub.publish_raw(b"\x80")
        assert got[1] == b"\x80"
        other = outside.create_publisher(JointState, "frames")
        wait_until(lambda: other.publish(state(2.0)) or len(got) > 2, 10, message="a frame from another process")
        assert isinstance(got[2], bytes)
    finally:
        outside.destroy()
        listener.destroy()
        talker.destroy()


def test_a_pulled_subscription_waiting_wakes_for_an_in_process_message(container_session: object) -> None:
    talker = Node("talker", session=container_session)
    stepper = Node("stepper", session=container_session)
    try:
        taken: list[bytes] = []
        sub = stepper.create_subscription(JointState, "hardware_like", taken.append,
                                          delivery=Pulled(), message=Raw())
        pub = talker.create_publisher(JointState, "hardware_like")
        assert sub.wait(0.05) == 0   # nothing yet: the wait times out
        timer = threading.Timer(0.2, lambda: pub.publish(state(1.0)))
        timer.start()
        started = time.monotonic()
        assert sub.wait(5.0) == 1
        assert time.monotonic() - started < 2.0, "woken by the message, not by the timeout"
        assert len(taken) == 1
        pub.publish(state(2.0))   # from this thread, while nobody waits: taken on the next look
        assert sub.take_pending() == 1 and len(taken) == 2
    finally:
        talker.destroy()
        stepper.destroy()


def test_a_container_node_still_rejects_bad_input_from_other_processes(router: str, container_session: object) -> None:
    talker = Node("talker", session=container_session)
    listener = Node("listener", session=container_session)
    outside = Node("outside", connect=[router])
    try:
        got: list[JointState] = []
        listener.create_subscription(JointState, "joint_states", got.append)
        talker.create_publisher(JointState, "joint_states")   # an in-process publisher on the same key
        hostile = outside.create_publisher(JointState, "joint_states")
        wait_until(lambda: hostile.publish(state(-1.0)) or got, 10, message="the listener hears the outside")
        time.sleep(0.3)   # the warm-up messages still on their way
        got.clear()
        for payload in (b"\xc1", b"\x93\x01\x02\x03", bytes(64)):   # not msgpack, not a map, zeros
            hostile.publish_raw(payload)
        nan_state = JointState(name=["a"], position=[float("nan")], velocity=[0.0], effort=[0.0])
        with pytest.raises(msgs.EncodeError, match=r"position\[0\]: not a finite number"):
            hostile.publish(nan_state)   # our publisher refuses it; a foreign one may still send it:
        hostile.publish_raw(msgs.packer(JointState._type)(name=["a"], position=[float("nan")], velocity=[0.0],
                                                          effort=[0.0]))
        hostile.publish(state(7.0))
        wait_until(lambda: got, 10, message="the good message after the bad ones")
        time.sleep(0.2)
        assert [m.position for m in got if m.position != [-1.0]] == [[7.0]], \
            "only the valid message reaches the callback"
    finally:
        for node in (talker, listener, outside):
            node.destroy()
