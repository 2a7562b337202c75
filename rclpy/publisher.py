"""rclpy.publisher: ``Publisher`` (over a ``nodes.core`` endpoint; created by the node's ``create_*``)."""

from rclpy._entities import Publisher

__all__ = ["Publisher"]
