"""rclpy.qos_event: the older name of ``rclpy.event_handler``."""

from rclpy.event_handler import (
    PublisherEventCallbacks,
    QoSPublisherEventType,
    QoSSubscriptionEventType,
    SubscriptionEventCallbacks,
)

__all__ = ["PublisherEventCallbacks", "QoSPublisherEventType", "QoSSubscriptionEventType",
           "SubscriptionEventCallbacks"]
