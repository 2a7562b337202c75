"""``Node.get_publishers_info_by_topic`` / ``get_subscriptions_info_by_topic``: the live graph's endpoints of a
topic with their QoS, read where ``ros2 topic info -v`` reads them (rmw_zenoh's liveliness tokens, so real
ROS 2 nodes are listed too), and zenroid endpoints that are not on the ROS 2 wire (``ZENROID_ROS2=0``,
internal keys) from our own graph with an unknown profile."""

from __future__ import annotations

from typing import Any

from nodes.core import graph, ros2
from nodes.core.ros2 import attachment
from nodes.core.ros2 import names as ros2_names
from nodes.core.ros2.endpoint_info import topic_endpoints
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
    found: list[TopicEndpointInfo] = []
    seen: set[tuple[str, str]] = set()   # (session id, node) on the ROS 2 wire
    if ros2.enabled():
        wire_kind = ros2_names.PUBLISHER if publishers else ros2_names.SUBSCRIPTION
        for entry in topic_endpoints(session, ros2.domain_id(), "/" + key.strip("/")):
            if entry.kind != wire_kind:
                continue
            fqn = "/" + "/".join(p for p in (entry.namespace.strip("/"), entry.node) if p)
            seen.add((entry.zid, fqn))
            found.append(TopicEndpointInfo(
                node_name=entry.node, node_namespace=entry.namespace, topic_type=entry.type_name,
                topic_type_hash=TypeHash.from_string(entry.type_hash), endpoint_type=kind,
                endpoint_gid=list(entry.gid), qos_profile=profile_of(entry.qos)))
    for entry in graph.snapshot(session, 0.3):
        if entry.kind != ("pub" if publishers else "sub") or entry.name != key or (entry.session_id, entry.node) in seen:
            continue
        namespace, _, name = entry.node.rpartition("/")
        found.append(TopicEndpointInfo(
            node_name=name, node_namespace=namespace or "/", topic_type=entry.type_name, endpoint_type=kind,
            endpoint_gid=list(attachment.make_gid(graph.endpoint_key(entry.kind, entry.session_id, entry.node,
                                                                     entry.name, entry.type_name))),
            qos_profile=qos_profile_unknown))
    return sorted(found, key=lambda i: (i.node_namespace, i.node_name))
