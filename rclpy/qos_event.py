"""rclpy.qos_event: the older name of ``rclpy.event_handler`` (Humble)."""

from rclpy.event_handler import *  # noqa: F403
from rclpy.event_handler import __all__  # noqa: F401
