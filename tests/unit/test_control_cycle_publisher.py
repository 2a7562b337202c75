"""A controller's publications during a control cycle: held back, and packed, until the cycle's hardware
command is out (nodes.control.node.CyclePublisher), as ros2_controllers' RealtimePublisher serialises off
the realtime thread."""

from __future__ import annotations

import threading
from types import SimpleNamespace
from typing import Any

import msgs
from nodes.control.node import CyclePublisher, send_held_back
from tests.support.control import ListLogger

JointState = msgs.get_type("sensor_msgs/msg/JointState")


class RecordingPublisher:
    """The manager node's own publisher, reduced to what CyclePublisher uses."""

    def __init__(self) -> None:
        self.msg_type, self.key = JointState, "robot/joint_states"
        self.sent: list[tuple[bytes, bool]] = []

    def publish_raw(self, payload: bytes, *, droppable: bool = False) -> None:
        self.sent.append((payload, droppable))


def _node(in_cycle: bool) -> Any:
    return SimpleNamespace(deferred_publications=[] if in_cycle else None,
                           cycle_thread=threading.get_ident(), realtime_hardware=True)


def _fields(position: list[float]) -> dict[str, Any]:
    return {"header": {"stamp": {"sec": 1, "nanosec": 5}, "frame_id": "base"}, "name": ["a", "b"],
            "position": position}


def test_fields_published_in_a_cycle_are_packed_and_sent_only_after_it() -> None:
    inner, node = RecordingPublisher(), _node(in_cycle=True)
    publisher = CyclePublisher(inner, node)
    publisher.publish_fields(**_fields([0.5, -1.0]))
    publisher.publish_raw(b"already packed")
    assert inner.sent == []   # nothing packed nor sent while the cycle runs
    assert isinstance(node.deferred_publications[0][1], dict)
    send_held_back(node.deferred_publications, ListLogger())
    first = msgs.decode(JointState, inner.sent[0][0])
    assert (first.name, first.position, first.header.frame_id) == (["a", "b"], [0.5, -1.0], "base")
    assert first.velocity == [] and first.header.stamp.nanosec == 5   # ROS defaults for the rest
    assert inner.sent[1] == (b"already packed", True)   # in order, droppable against realtime hardware


def test_fields_published_outside_a_cycle_go_at_once() -> None:
    inner = RecordingPublisher()
    CyclePublisher(inner, _node(in_cycle=False)).publish_fields(**_fields([1.0, 2.0]))
    assert msgs.decode(JointState, inner.sent[0][0]).position == [1.0, 2.0]


def test_a_message_that_does_not_pack_is_dropped_with_its_topic_named_and_the_rest_still_go() -> None:
    inner, node, logger = RecordingPublisher(), _node(in_cycle=True), ListLogger()
    publisher = CyclePublisher(inner, node)
    publisher.publish_fields(**_fields(["not a number", 1.0]))
    publisher.publish_fields(no_such_field=1)
    publisher.publish_fields(header={"stamp": {"sec": 10**30, "nanosec": 0}})   # msgpack: integer out of range
    publisher.publish_fields(**_fields([3.0, 4.0]))
    send_held_back(node.deferred_publications, logger)
    assert [msgs.decode(JointState, payload).position for payload, _ in inner.sent] == [[3.0, 4.0]]
    warnings = logger.text("warn")
    assert warnings.count("robot/joint_states: dropped a controller's message that does not pack") == 3
    assert "could not convert string to float" in warnings and "no_such_field" in warnings
    assert "out of range" in warnings
