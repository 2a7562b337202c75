"""rclpy.client: ``Client`` (over a ``nodes.core`` endpoint; created by the node's ``create_*``)."""

from rclpy._entities import Client

__all__ = ["Client"]
