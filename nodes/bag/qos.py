"""The QoS a recorded topic is offered with, as rosbag2 stores it, and which topics are latched.

Zenoh has no per-publisher QoS to discover, so a recording says what an rclcpp publisher with default QoS
offers: reliable, keep-last 10, volatile, no deadlines; latched topics (tf_static, robot_description) are
transient local with depth 1, so ``ros2 bag play`` (and ours) republishes them latched.
"""

from __future__ import annotations

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

# RMW_DURATION_INFINITE (INT64_MAX ns) as rosbag2 writes it: whole seconds and the nanosecond rest.
INFINITE = QosTime(sec=9223372036, nsec=854775807)
LATCHED_SUFFIXES = ("tf_static", "robot_description")


def is_latched(topic: str) -> bool:
    return topic.rstrip("/").rsplit("/", 1)[-1] in LATCHED_SUFFIXES


def offered_qos(topic: str) -> list[Qos]:
    latched = is_latched(topic)
    return [Qos(history=QosHistory.KEEP_LAST, depth=1 if latched else 10, reliability=QosReliability.RELIABLE,
                durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
                deadline=INFINITE, lifespan=INFINITE, liveliness=QosLiveliness.AUTOMATIC,
                liveliness_lease_duration=INFINITE, avoid_ros_namespace_conventions=False)]


def offered_latched(profiles: list[Qos], topic: str) -> bool:
    """Whether a recorded topic is replayed latched: its first offered profile says, else its name."""
    if profiles:
        return profiles[0].durability == QosDurability.TRANSIENT_LOCAL
    return is_latched(topic)
