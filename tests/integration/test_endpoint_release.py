"""A destroyed endpoint lets go of its owner at once (reference counting, not the cyclic GC).

An object that holds its endpoints and gives them its own methods as callbacks (a spawned robot's link in the
simulator: a command subscription, an info service, state publishers) forms a reference cycle with them. Left
to the cyclic GC, a deleted robot and everything it holds (its DART skeleton, its Zenoh entities) waits for a
full collection, which a process with many long-lived objects runs rarely: spawn/delete churn then looks like
a leak of tens of kB per robot. Destroying the endpoints must break every such cycle, the ROS 2 twins' too.
"""

from __future__ import annotations

import gc
import weakref

import msgs
from nodes.core import Node
from nodes.core.delivery import Batched, Pulled, Raw

Trigger = msgs.get_type("std_srvs/srv/Trigger")
JointState = msgs.get_type("sensor_msgs/msg/JointState")
Navigate = msgs.get_type("humanoid_msgs/action/NavigateToGoal")


class _Owner:
    """Holds its endpoints and hands them its bound methods, as the simulator's robot link does."""

    def __init__(self, node: Node, ns: str) -> None:
        self.node = node
        self.endpoints = [
            node.create_publisher(JointState, f"/{ns}/state"),
            node.create_subscription(JointState, f"/{ns}/command", self.on_message),
            node.create_subscription(JointState, f"/{ns}/pulled", self.on_message, delivery=Pulled(),
                                     message=Raw()),
            node.create_subscription(JointState, f"/{ns}/rated", self.on_message, delivery=Batched(50.0)),
            node.create_service(Trigger, f"/{ns}/info", self.on_request),
            node.create_client(Trigger, f"/{ns}/other"),
            node.create_action_server(Navigate, f"/{ns}/go", execute_callback=self.on_goal),
            node.create_action_client(Navigate, f"/{ns}/go_elsewhere"),
        ]

    def on_message(self, *_: object) -> None:
        pass

    def on_request(self, _request: object) -> object:
        return Trigger.Response(success=True)

    def on_goal(self, _handle: object) -> object:
        return Navigate.Result()

    def destroy(self) -> None:
        for endpoint in self.endpoints:
            self.node.destroy_entity(endpoint)


def test_destroyed_endpoints_free_their_owner_without_the_cyclic_gc(router: str) -> None:
    node = Node("release_probe", connect=[router])
    try:
        _Owner(node, "warm").destroy()   # first use: lazily built caches are not what this test looks for
        gc.collect()
        gc.disable()
        try:
            owner = _Owner(node, "robot")
            twins = [e._mirror for e in owner.endpoints if getattr(e, "_mirror", None) is not None]
            assert twins, "the ROS 2 wire is on by default: every endpoint here has a twin"
            # a subscription and its delivery object refer to each other (small, and no owner in it)
            watched = [weakref.ref(owner), *(weakref.ref(t) for t in twins),
                       *(weakref.ref(e) for e in owner.endpoints if not hasattr(e, "delivery"))]
            owner.destroy()
            del owner, twins
            alive = [type(ref()).__name__ for ref in watched if ref() is not None]
        finally:
            gc.enable()
        assert alive == [], f"still referenced after destroy (held by a reference cycle): {alive}"
    finally:
        node.destroy()
