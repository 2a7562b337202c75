"""rclpy.lifecycle: managed nodes over ``nodes.core.lifecycle`` (the services ``zenroid lifecycle`` drives)."""

from rclpy.lifecycle.node import (
    LifecycleNode,
    LifecycleNodeMixin,
    LifecyclePublisher,
    LifecycleState,
    ManagedEntity,
    SimpleManagedEntity,
    State,
    TransitionCallbackReturn,
)

Node = LifecycleNode
Publisher = LifecyclePublisher

__all__ = ["LifecycleNode", "LifecycleNodeMixin", "LifecyclePublisher", "LifecycleState", "ManagedEntity", "Node",
           "Publisher", "SimpleManagedEntity", "State", "TransitionCallbackReturn"]
