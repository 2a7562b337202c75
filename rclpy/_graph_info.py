"""``Node.get_publishers_info_by_topic`` / ``get_subscriptions_info_by_topic``: the live graph's endpoints of a
topic with their QoS (``nodes.core.ros2.endpoint_info``: rmw_zenoh's liveliness tokens, as ``ros2 topic info
-v`` reads them, so real ROS 2 nodes are listed too; zenroid endpoints off the ROS 2 wire with an unknown
profile)."""

from __future__ import annotations

from typing import Any

from nodes.core import ros2
from nodes.core.ros2 import names as ros2_names
from nodes.core.ros2.endpoint_info import endpoints_of
from rclpy.duration import Duration, Infinite
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_unknown,
)
from rclpy.topic_endpoint_info import TopicEndpointInfo, TopicEndpointTypeEnum, TypeHash


def profile_of(qos: ros2_names.Qos) -> QoSProfile:
    """A token's QoS as the QoSProfile rclpy reports (infinite durations as ``Infinite``)."""
    def duration(ns: int) -> Duration:
        return Duration(nanoseconds=ns) if ns > 0 else Infinite

    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if qos.keep_all else HistoryPolicy.KEEP_LAST,
        depth=0 if qos.keep_all else qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.transient_local else DurabilityPolicy.VOLATILE,
        deadline=duration(qos.deadline_ns), lifespan=duration(qos.lifespan_ns),
        liveliness=LivelinessPolicy.MANUAL_BY_TOPIC if qos.liveliness == 3 else LivelinessPolicy.AUTOMATIC,
        liveliness_lease_duration=duration(qos.lease_ns))


def topic_info(session: Any, key: str, publishers: bool) -> list[TopicEndpointInfo]:
    """The endpoints of our ``key`` (publishers or subscriptions)."""
    kind = TopicEndpointTypeEnum.PUBLISHER if publishers else TopicEndpointTypeEnum.SUBSCRIPTION
    return [TopicEndpointInfo(
        node_name=entry.node, node_namespace=entry.namespace, topic_type=entry.type_name,
        topic_type_hash=TypeHash.from_string(entry.type_hash), endpoint_type=kind, endpoint_gid=list(entry.gid),
        qos_profile=qos_profile_unknown if entry.qos is None else profile_of(entry.qos))
        for entry in endpoints_of(session, key, publishers, domain=ros2.domain_id() if ros2.enabled() else None)]
