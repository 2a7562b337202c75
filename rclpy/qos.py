"""QoS profiles and policies as rclpy spells them, and what each means over Zenoh (docs/rclpy.md, QoS):

- reliability RELIABLE: a publisher that waits rather than drops under congestion; BEST_EFFORT: drops;
- durability TRANSIENT_LOCAL: the publisher keeps its last message and a late subscription fetches it when it
  is created (``nodes/core/latched.py``); Zenoh keeps one message per publisher, not ``depth``;
- history/depth: KEEP_LAST bounds what waits for the spinning thread to ``depth`` messages per subscription,
  the newest kept (``queue_depth``; rmw_zenoh's subscription queue); KEEP_ALL keeps all;
- deadline, lifespan and liveliness: ``rclpy/_qos_events.py`` (docs/rclpy.md, QoS events).
"""

from __future__ import annotations

import enum
from typing import Any

from rclpy.duration import Duration


class QoSPolicyKind(enum.IntEnum):
    INVALID = 1 << 0
    DURABILITY = 1 << 1
    DEADLINE = 1 << 2
    LIVELINESS = 1 << 3
    RELIABILITY = 1 << 4
    HISTORY = 1 << 5
    LIFESPAN = 1 << 6


class HistoryPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2
    UNKNOWN = 3


class ReliabilityPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class DurabilityPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class LivelinessPolicy(enum.IntEnum):
    SYSTEM_DEFAULT = 0
    AUTOMATIC = 1
    MANUAL_BY_TOPIC = 3
    UNKNOWN = 4
    BEST_AVAILABLE = 5


# the old names rclpy still accepts
QoSHistoryPolicy = HistoryPolicy
QoSReliabilityPolicy = ReliabilityPolicy
QoSDurabilityPolicy = DurabilityPolicy
QoSLivelinessPolicy = LivelinessPolicy


class QoSProfile:
    __slots__ = ("_history", "_depth", "_reliability", "_durability", "_lifespan", "_deadline", "_liveliness",
                 "_liveliness_lease_duration", "_avoid_ros_namespace_conventions")

    def __init__(self, **kwargs: Any) -> None:
        unknown = set(kwargs) - {s.lstrip("_") for s in self.__slots__}
        if unknown:
            raise TypeError(f"QoSProfile got unknown argument(s): {', '.join(sorted(unknown))}")
        if "history" not in kwargs and "depth" not in kwargs:
            raise TypeError("QoSProfile must be given at least one of history or depth")
        self.history = kwargs.get("history", HistoryPolicy.KEEP_LAST)
        self.depth = kwargs.get("depth", 0)
        self.reliability = kwargs.get("reliability", ReliabilityPolicy.RELIABLE)
        self.durability = kwargs.get("durability", DurabilityPolicy.VOLATILE)
        self.lifespan = kwargs.get("lifespan", Duration())
        self.deadline = kwargs.get("deadline", Duration())
        self.liveliness = kwargs.get("liveliness", LivelinessPolicy.SYSTEM_DEFAULT)
        self.liveliness_lease_duration = kwargs.get("liveliness_lease_duration", Duration())
        self.avoid_ros_namespace_conventions = kwargs.get("avoid_ros_namespace_conventions", False)

    def _enum(self, cls: type, value: Any) -> Any:
        if isinstance(value, str):
            return cls[value.upper()]
        return cls(value)

    history = property(lambda self: self._history,
                       lambda self, v: setattr(self, "_history", self._enum(HistoryPolicy, v)))
    reliability = property(lambda self: self._reliability,
                           lambda self, v: setattr(self, "_reliability", self._enum(ReliabilityPolicy, v)))
    durability = property(lambda self: self._durability,
                          lambda self, v: setattr(self, "_durability", self._enum(DurabilityPolicy, v)))
    liveliness = property(lambda self: self._liveliness,
                          lambda self, v: setattr(self, "_liveliness", self._enum(LivelinessPolicy, v)))

    @property
    def depth(self) -> int:
        return self._depth

    @depth.setter
    def depth(self, value: int) -> None:
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ValueError(f"QoS depth must be an int >= 0, got {value!r}")
        self._depth = value

    lifespan = property(lambda self: self._lifespan, lambda self, v: setattr(self, "_lifespan", v))
    deadline = property(lambda self: self._deadline, lambda self, v: setattr(self, "_deadline", v))
    liveliness_lease_duration = property(lambda self: self._liveliness_lease_duration,
                                         lambda self, v: setattr(self, "_liveliness_lease_duration", v))
    avoid_ros_namespace_conventions = property(
        lambda self: self._avoid_ros_namespace_conventions,
        lambda self, v: setattr(self, "_avoid_ros_namespace_conventions", bool(v)))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, QoSProfile):
            return False
        return all(getattr(self, s) == getattr(other, s) for s in self.__slots__)

    def __repr__(self) -> str:
        return (f"QoSProfile(history={self.history.name}, depth={self.depth}, reliability={self.reliability.name}, "
                f"durability={self.durability.name})")


def qos_profile_from_depth(qos: Any) -> QoSProfile:
    """rclpy's ``create_publisher(..., 10)``: an int is a KEEP_LAST depth."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, int) and not isinstance(qos, bool):
        return QoSProfile(depth=qos)
    raise TypeError(f"qos_profile must be a QoSProfile or an int depth, got {type(qos).__name__}")


# rmw_zenoh's depth for a KEEP_LAST profile that names none (depth 0, SYSTEM_DEFAULT)
RMW_ZENOH_DEFAULT_HISTORY_DEPTH = 42


def queue_depth(qos: QoSProfile) -> int | None:
    """How many messages may wait for a subscription's callback, the newest kept (None: all of them), as
    rmw_zenoh bounds its subscription queue: KEEP_LAST its depth (0: rmw_zenoh's 42), KEEP_ALL no bound."""
    if qos.history == HistoryPolicy.KEEP_ALL:
        return None
    return qos.depth if qos.depth > 0 else RMW_ZENOH_DEFAULT_HISTORY_DEPTH


def latched_depth(qos: QoSProfile) -> int:
    """How many of its last messages a TRANSIENT_LOCAL publisher keeps for late joiners, and how many of
    them a late-joining subscription takes: the depth, KEEP_ALL too (0: rmw_zenoh's 42), as rmw_zenoh sizes
    its publisher cache and its subscriber's history, so our key and the ROS 2 twin keep the same."""
    return qos.depth if qos.depth > 0 else RMW_ZENOH_DEFAULT_HISTORY_DEPTH


qos_profile_system_default = QoSProfile(history=HistoryPolicy.SYSTEM_DEFAULT,
                                        reliability=ReliabilityPolicy.SYSTEM_DEFAULT,
                                        durability=DurabilityPolicy.SYSTEM_DEFAULT)
qos_profile_sensor_data = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                                     reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
qos_profile_services_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                                          reliability=ReliabilityPolicy.RELIABLE,
                                          durability=DurabilityPolicy.VOLATILE)
qos_profile_parameters = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
qos_profile_parameter_events = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                          reliability=ReliabilityPolicy.RELIABLE,
                                          durability=DurabilityPolicy.VOLATILE)
qos_profile_action_status_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                                               reliability=ReliabilityPolicy.RELIABLE,
                                               durability=DurabilityPolicy.TRANSIENT_LOCAL)
qos_profile_rosout_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                        reliability=ReliabilityPolicy.RELIABLE,
                                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
qos_profile_best_available = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                                        reliability=ReliabilityPolicy.BEST_AVAILABLE,
                                        durability=DurabilityPolicy.BEST_AVAILABLE)
qos_profile_unknown = QoSProfile(history=HistoryPolicy.UNKNOWN, reliability=ReliabilityPolicy.UNKNOWN,
                                 durability=DurabilityPolicy.UNKNOWN)


class QoSPresetProfiles(enum.Enum):
    UNKNOWN = qos_profile_unknown
    SYSTEM_DEFAULT = qos_profile_system_default
    SENSOR_DATA = qos_profile_sensor_data
    SERVICES_DEFAULT = qos_profile_services_default
    PARAMETERS = qos_profile_parameters
    PARAMETER_EVENTS = qos_profile_parameter_events
    ACTION_STATUS_DEFAULT = qos_profile_action_status_default
    BEST_AVAILABLE = qos_profile_best_available

    @classmethod
    def get_from_short_key(cls, name: str) -> QoSProfile:
        return cls[name.upper()].value


class QoSCompatibility(enum.IntEnum):
    OK = 0
    WARNING = 1
    ERROR = 2


def qos_check_compatible(publisher_qos: QoSProfile, subscription_qos: QoSProfile) -> tuple[QoSCompatibility, str]:
    if (publisher_qos.reliability == ReliabilityPolicy.BEST_EFFORT
            and subscription_qos.reliability == ReliabilityPolicy.RELIABLE):
        return QoSCompatibility.ERROR, "ERROR: Best effort publisher and reliable subscription;"
    if (publisher_qos.durability == DurabilityPolicy.VOLATILE
            and subscription_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL):
        return QoSCompatibility.ERROR, "ERROR: Volatile publisher and transient local subscription;"
    return QoSCompatibility.OK, ""
