"""rclpy.service: ``Service`` (over a ``nodes.core`` endpoint; created by the node's ``create_*``)."""

from rclpy._entities import Service

__all__ = ["Service"]
