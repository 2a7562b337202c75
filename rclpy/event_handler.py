"""QoS event callbacks (deadline, liveliness, incompatible QoS, message lost): accepted by
``create_publisher``/``create_subscription`` and never called, since Zenoh raises none of these events
(docs/rclpy.md, QoS)."""

from __future__ import annotations

from typing import Any


class SubscriptionEventCallbacks:
    def __init__(self, *, deadline: Any = None, incompatible_qos: Any = None, liveliness: Any = None,
                 message_lost: Any = None, use_default_callbacks: bool = True, incompatible_type: Any = None,
                 matched: Any = None) -> None:
        self.deadline, self.incompatible_qos, self.liveliness = deadline, incompatible_qos, liveliness
        self.message_lost, self.use_default_callbacks = message_lost, use_default_callbacks
        self.incompatible_type, self.matched = incompatible_type, matched


class PublisherEventCallbacks:
    def __init__(self, *, deadline: Any = None, liveliness: Any = None, incompatible_qos: Any = None,
                 use_default_callbacks: bool = True, incompatible_type: Any = None, matched: Any = None) -> None:
        self.deadline, self.liveliness, self.incompatible_qos = deadline, liveliness, incompatible_qos
        self.use_default_callbacks, self.incompatible_type, self.matched = use_default_callbacks, \
            incompatible_type, matched


class QoSPublisherEventType:
    RCL_PUBLISHER_OFFERED_DEADLINE_MISSED = 0
    RCL_PUBLISHER_LIVELINESS_LOST = 1
    RCL_PUBLISHER_OFFERED_INCOMPATIBLE_QOS = 2


class QoSSubscriptionEventType:
    RCL_SUBSCRIPTION_REQUESTED_DEADLINE_MISSED = 0
    RCL_SUBSCRIPTION_LIVELINESS_CHANGED = 1
    RCL_SUBSCRIPTION_REQUESTED_INCOMPATIBLE_QOS = 2
    RCL_SUBSCRIPTION_MESSAGE_LOST = 3
