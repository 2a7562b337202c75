"""rclpy's ParameterEventHandler on zenroid: which callbacks an event reaches (node names resolved against the
handler node's namespace, newest callback first, removal, the static helpers), and which events an rclpy node
publishes on /parameter_events for each way its parameters change (rclpy Jazzy's rules), read back by a
handler and by ``AsyncParameterClient.on_parameter_event`` in the same process over a real router."""

from __future__ import annotations

from typing import Any

import pytest

import msgs
from rclpy.parameter import Parameter
from rclpy.parameter_event_handler import ParameterEventHandler
from tests.conftest import wait_until

ParameterEvent = msgs.get_type("rcl_interfaces/msg/ParameterEvent")


class FakeNode:
    """What the handler asks of its node: a subscription (kept here) and its names."""

    def __init__(self, namespace: str = "/", name: str = "watcher") -> None:
        self.namespace, self.name = namespace, name
        self.subscriptions: list[tuple[Any, ...]] = []

    def get_namespace(self) -> str:
        return self.namespace

    def get_fully_qualified_name(self) -> str:
        return f"{self.namespace.rstrip('/')}/{self.name}"

    def create_subscription(self, msg_type: Any, topic: str, callback: Any, qos: Any, **kwargs: Any) -> Any:
        self.subscriptions.append((msg_type, topic, callback, qos, kwargs))
        return len(self.subscriptions)

    def destroy_subscription(self, subscription: Any) -> bool:
        self.subscriptions = [s for i, s in enumerate(self.subscriptions, 1) if i != subscription]
        return True


def event(node: str, new: dict | None = None, changed: dict | None = None, deleted: list | None = None) -> Any:
    def params(values: dict) -> list:
        return [Parameter(n, value=v).to_parameter_msg() for n, v in values.items()]

    return ParameterEvent(node=node, new_parameters=params(new or {}), changed_parameters=params(changed or {}),
                          deleted_parameters=[Parameter(n).to_parameter_msg() for n in deleted or []])


def test_the_handler_subscribes_to_parameter_events_with_rclpys_qos() -> None:
    from rclpy.qos import qos_profile_parameter_events

    node = FakeNode()
    handler = ParameterEventHandler(node, raw=False)
    msg_type, topic, callback, qos, kwargs = node.subscriptions[0]
    assert (msg_type, topic, qos) == (ParameterEvent, "/parameter_events", qos_profile_parameter_events)
    assert qos.depth == 1000 and set(kwargs) == {"callback_group", "event_callbacks", "qos_overriding_options",
                                                 "raw"}
    handler.destroy()
    assert node.subscriptions == []


def test_parameter_callbacks_filter_by_node_and_parameter_newest_first() -> None:
    node = FakeNode(namespace="/lab")
    handler = ParameterEventHandler(node)
    deliver = node.subscriptions[0][2]
    calls: list[tuple[str, str, Any]] = []

    def recorder(tag: str):
        return lambda p: calls.append((tag, p.name, Parameter.from_parameter_msg(p).value))

    relative = handler.add_parameter_callback("gain", "tuner", recorder("relative"))      # /lab/tuner
    absolute = handler.add_parameter_callback("gain", "/tuner", recorder("absolute"))     # /tuner
    handler.add_parameter_callback("gain", "/lab/tuner", recorder("newest"))              # same key as relative
    handler.add_parameter_callback("rate", "", recorder("self"))                          # /lab/watcher itself
    seen: list[Any] = []
    events = handler.add_parameter_event_callback(seen.append)

    deliver(event("/lab/tuner", changed={"gain": 2.5, "other": 1}))
    assert calls == [("newest", "gain", 2.5), ("relative", "gain", 2.5)]
    calls.clear()
    deliver(event("/tuner", new={"gain": 7}))
    deliver(event("/lab/watcher", changed={"rate": 5.0}))
    deliver(event("/lab/tuner", deleted=["gain"]))          # a deletion is not a value: no parameter callback
    deliver(event("/lab/other", changed={"gain": 1.0}))
    assert calls == [("absolute", "gain", 7), ("self", "rate", 5.0)]
    assert [e.node for e in seen] == ["/lab/tuner", "/tuner", "/lab/watcher", "/lab/tuner", "/lab/other"]

    handler.remove_parameter_callback(relative)
    handler.remove_parameter_callback(absolute)
    handler.remove_parameter_event_callback(events)
    calls.clear()
    deliver(event("/lab/tuner", changed={"gain": 3.0}))
    deliver(event("/tuner", changed={"gain": 3.0}))
    assert calls == [("newest", "gain", 3.0)] and len(seen) == 5
    with pytest.raises(RuntimeError, match="Callback doesn't exist"):
        handler.remove_parameter_callback(relative)
    with pytest.raises(RuntimeError, match="Callback doesn't exist"):
        handler.remove_parameter_event_callback(events)


def test_a_callback_may_add_and_remove_callbacks() -> None:
    node = FakeNode()
    handler = ParameterEventHandler(node)
    deliver = node.subscriptions[0][2]
    seen: list[str] = []
    handles: list[Any] = []

    def once(e: Any) -> None:
        seen.append(e.node)
        handler.remove_parameter_event_callback(handles[0])
        handler.add_parameter_callback("gain", e.node, lambda p: seen.append(p.name))

    handles.append(handler.add_parameter_event_callback(once))
    deliver(event("/a", changed={"gain": 1.0}))
    deliver(event("/a", changed={"gain": 2.0}))
    assert seen == ["/a", "gain"]


def test_the_static_helpers() -> None:
    e = event("/n", new={"a": 1}, changed={"b": "x"}, deleted=["c"])
    assert [p.name for p in ParameterEventHandler.get_parameters_from_event(e)] == ["a", "b"]
    assert ParameterEventHandler.get_parameter_from_event(e, "b", "/n").value.string_value == "x"
    assert ParameterEventHandler.get_parameter_from_event(e, "c", "/n") is None     # deleted
    assert ParameterEventHandler.get_parameter_from_event(e, "a", "n") is None      # names are fully qualified


def test_an_rclpy_node_publishes_rclpys_events(context) -> None:
    """Declared: new (NOT_SET while statically typed and unset); set: changed, or new when it had no value;
    set_parameters: one event per parameter, set_parameters_atomically: one for all; NOT_SET: deleted;
    undeclare_parameter and refused sets: none (rclpy's)."""
    from rcl_interfaces.msg import SetParametersResult

    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter_client import AsyncParameterClient

    watcher = rclpy.create_node("watcher", context=context)
    node = rclpy.create_node("tuned", namespace="lab", context=context,
                             parameter_overrides=[Parameter("from_launch", value=3)])
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(watcher)
    events: list[Any] = []
    from_client: list[Any] = []
    AsyncParameterClient(watcher, "/lab/tuned").on_parameter_event(from_client.append)   # every node's
    handler = ParameterEventHandler(watcher)
    handler.add_parameter_event_callback(lambda e: events.append(e) if e.node == "/lab/tuned" else None)
    gains: list[float] = []
    handler.add_parameter_callback("gain", "/lab/tuned", lambda p: gains.append(p.value.double_value))
    wait_until(lambda: node._zr_events.publisher.has_subscribers, message="the handler's subscription")

    def summary(e: Any) -> tuple:
        def pairs(params: list) -> list:
            return [(p.name, Parameter.from_parameter_msg(p).value) for p in params]

        return pairs(e.new_parameters), pairs(e.changed_parameters), pairs(e.deleted_parameters)

    node.declare_parameter("gain", 1.5)
    node.declare_parameter("from_launch", 0)
    node.declare_parameter("limit", Parameter.Type.DOUBLE)
    node.declare_parameter("free", None, rclpy.node.ParameterDescriptor(dynamic_typing=True))
    node.add_on_set_parameters_callback(
        lambda ps: SetParametersResult(successful=all(p.value != 13.0 for p in ps), reason="unlucky"))
    node.set_parameters([Parameter("gain", value=2.5), Parameter("limit", value=9.0)])
    node.set_parameters([Parameter("gain", value=13.0)])                     # refused: no event
    node.set_parameters_atomically([Parameter("gain", value=3.5), Parameter("free", value="on")])
    node.set_parameters([Parameter("free")])                                # NOT_SET: deleted
    node.undeclare_parameter("limit")                                        # rclpy publishes nothing
    node.set_parameters([Parameter("gain", value=4.5)])
    expected = [
        ([("gain", 1.5)], [], []), ([("from_launch", 3)], [], []), ([("limit", None)], [], []),
        ([("free", None)], [], []),
        ([], [("gain", 2.5)], []), ([("limit", 9.0)], [], []),
        ([("free", "on")], [("gain", 3.5)], []),
        ([], [], [("free", None)]),
        ([], [("gain", 4.5)], []),
    ]
    wait_until(lambda: executor.spin_once(timeout_sec=0.05) or len(events) >= len(expected), timeout=20,
               message=f"{len(expected)} events; got {[summary(e) for e in events]}")
    assert [summary(e) for e in events] == expected
    assert gains == [1.5, 2.5, 3.5, 4.5]
    wait_until(lambda: executor.spin_once(timeout_sec=0.05) or len(from_client) >= len(events), timeout=20,
               message="the parameter client's subscription")
    assert [summary(e) for e in from_client if e.node == "/lab/tuned"] == expected
    assert all(e.stamp.sec > 0 for e in events)
    node.destroy_node()
    watcher.destroy_node()


def test_the_ros2_twin_announces_what_a_jazzy_node_announces() -> None:
    """The QoS and type hash of a Jazzy talker's /parameter_events publisher token (rmw_zenoh, captured from
    a real ROS 2 graph)."""
    from msgs.type_hash import rihs01
    from nodes.core.parameter_events import QOS

    assert QOS.token() == "::,1000:,:,:,,"
    assert rihs01("rcl_interfaces/msg/ParameterEvent") == \
        "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204"
