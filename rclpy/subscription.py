"""rclpy.subscription: ``Subscription`` (over a ``nodes.core`` endpoint; created by the node's ``create_*``)."""

from rclpy._entities import Subscription

__all__ = ["Subscription"]
