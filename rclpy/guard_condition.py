"""rclpy.guard_condition: ``GuardCondition`` (over a ``nodes.core`` endpoint; created by the node's ``create_*``)."""

from rclpy._entities import GuardCondition

__all__ = ["GuardCondition"]
