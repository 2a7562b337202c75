"""QoS event callbacks as rclpy names them (``rclpy.event_handler``; ``rclpy.qos_event`` before Iron).

Called (docs/rclpy.md, QoS events; ``rclpy/_qos_events.py``): the deadline of subscriptions and publishers,
a subscription's liveliness (its publishers appearing, going away or, MANUAL_BY_TOPIC, not asserting within
the lease), a MANUAL_BY_TOPIC publisher's lost liveliness and both sides' matched. The callbacks run on the
executor like the entity's other callbacks. Incompatible QoS, message lost and incompatible type callbacks
are accepted and never called, as on rmw_zenoh (Zenoh connects every publisher with every subscription of a
key).
"""

from __future__ import annotations

import enum
from typing import Any


class _Status:
    """An rmw status struct: named int fields, equality and a repr."""

    __slots__: tuple[str, ...] = ()

    def __init__(self, **fields: int) -> None:
        for name in self.__slots__:
            setattr(self, name, fields.pop(name, 0))
        if fields:
            raise TypeError(f"{type(self).__name__} has no field(s) {', '.join(sorted(fields))}")

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and all(getattr(self, n) == getattr(other, n) for n in self.__slots__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{n}={getattr(self, n)}' for n in self.__slots__)})"


class QoSRequestedDeadlineMissedInfo(_Status):
    __slots__ = ("total_count", "total_count_change")


class QoSOfferedDeadlineMissedInfo(_Status):
    __slots__ = ("total_count", "total_count_change")


class QoSLivelinessChangedInfo(_Status):
    __slots__ = ("alive_count", "not_alive_count", "alive_count_change", "not_alive_count_change")


class QoSLivelinessLostInfo(_Status):
    __slots__ = ("total_count", "total_count_change")


class QoSMessageLostInfo(_Status):
    __slots__ = ("total_count", "total_count_change")


class QoSRequestedIncompatibleQoSInfo(_Status):
    __slots__ = ("total_count", "total_count_change", "last_policy_kind")


QoSOfferedIncompatibleQoSInfo = QoSRequestedIncompatibleQoSInfo


class IncompatibleTypeInfo(_Status):
    __slots__ = ("total_count", "total_count_change")


class QoSSubscriptionMatchedInfo(_Status):
    __slots__ = ("total_count", "total_count_change", "current_count", "current_count_change")


QoSPublisherMatchedInfo = QoSSubscriptionMatchedInfo


class UnsupportedEventTypeError(Exception):
    """Raised when registering a callback for an event type that is not supported."""


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


class QoSPublisherEventType(enum.IntEnum):
    RCL_PUBLISHER_OFFERED_DEADLINE_MISSED = 0
    RCL_PUBLISHER_LIVELINESS_LOST = 1
    RCL_PUBLISHER_OFFERED_INCOMPATIBLE_QOS = 2
    RCL_PUBLISHER_INCOMPATIBLE_TYPE = 3
    RCL_PUBLISHER_MATCHED = 4


class QoSSubscriptionEventType(enum.IntEnum):
    RCL_SUBSCRIPTION_REQUESTED_DEADLINE_MISSED = 0
    RCL_SUBSCRIPTION_LIVELINESS_CHANGED = 1
    RCL_SUBSCRIPTION_REQUESTED_INCOMPATIBLE_QOS = 2
    RCL_SUBSCRIPTION_MESSAGE_LOST = 3
    RCL_SUBSCRIPTION_INCOMPATIBLE_TYPE = 4
    RCL_SUBSCRIPTION_MATCHED = 5


__all__ = ["IncompatibleTypeInfo", "PublisherEventCallbacks", "QoSLivelinessChangedInfo", "QoSLivelinessLostInfo",
           "QoSMessageLostInfo", "QoSOfferedDeadlineMissedInfo", "QoSOfferedIncompatibleQoSInfo",
           "QoSPublisherEventType", "QoSPublisherMatchedInfo", "QoSRequestedDeadlineMissedInfo",
           "QoSRequestedIncompatibleQoSInfo", "QoSSubscriptionEventType", "QoSSubscriptionMatchedInfo",
           "SubscriptionEventCallbacks", "UnsupportedEventTypeError"]
