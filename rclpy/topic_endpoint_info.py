"""``TopicEndpointInfo`` as rclpy has it: what ``Node.get_publishers_info_by_topic`` and
``get_subscriptions_info_by_topic`` return, and ``ros2 topic info -v`` prints."""

from __future__ import annotations

import enum
from typing import Any

from rclpy.qos import HistoryPolicy, QoSProfile, qos_profile_unknown


class TopicEndpointTypeEnum(enum.IntEnum):
    INVALID = 0
    PUBLISHER = 1
    SUBSCRIPTION = 2


class TypeHash:
    __slots__ = ("version", "value")

    def __init__(self, version: int = -1, value: bytes = bytes(32)) -> None:
        self.version, self.value = version, value

    @classmethod
    def from_string(cls, text: str) -> TypeHash:
        """``RIHS01_<64 hex digits>`` (what rmw_zenoh's tokens carry); the empty hash for anything else."""
        head, _, digits = text.partition("_")
        try:
            return cls(int(head[4:]), bytes.fromhex(digits)) if head.startswith("RIHS") else cls()
        except ValueError:
            return cls()

    def __eq__(self, other: object) -> bool:
        return isinstance(other, TypeHash) and (self.version, self.value) == (other.version, other.value)

    def __str__(self) -> str:
        return f"RIHS{self.version:02d}_{self.value.hex()}" if self.version >= 0 else "INVALID"

    __repr__ = __str__


class TopicEndpointInfo:
    __slots__ = ("node_name", "node_namespace", "topic_type", "topic_type_hash", "endpoint_type", "endpoint_gid",
                 "qos_profile")

    def __init__(self, node_name: str = "", node_namespace: str = "", topic_type: str = "",
                 topic_type_hash: TypeHash | None = None,
                 endpoint_type: TopicEndpointTypeEnum = TopicEndpointTypeEnum.INVALID,
                 endpoint_gid: list[int] | None = None, qos_profile: QoSProfile = qos_profile_unknown) -> None:
        self.node_name, self.node_namespace, self.topic_type = node_name, node_namespace, topic_type
        self.topic_type_hash = topic_type_hash or TypeHash()
        self.endpoint_type = TopicEndpointTypeEnum(endpoint_type)
        self.endpoint_gid = list(endpoint_gid or [])
        self.qos_profile = qos_profile

    def __eq__(self, other: Any) -> bool:
        return isinstance(other, TopicEndpointInfo) and all(
            getattr(self, slot) == getattr(other, slot) for slot in self.__slots__)

    def __repr__(self) -> str:
        return f"TopicEndpointInfo({self.endpoint_type.name} {self.node_namespace.rstrip('/')}/{self.node_name})"

    def __str__(self) -> str:
        gid = ".".join(format(x, "02x") for x in self.endpoint_gid)
        qos = self.qos_profile
        depth = qos.history.name if qos.history != HistoryPolicy.KEEP_LAST else f"{qos.history.name} ({qos.depth})"
        return "\n".join([
            f"Node name: {self.node_name}",
            f"Node namespace: {self.node_namespace}",
            f"Topic type: {self.topic_type}",
            f"Topic type hash: {self.topic_type_hash}",
            f"Endpoint type: {self.endpoint_type.name}",
            f"GID: {gid}",
            "QoS profile:",
            f"  Reliability: {qos.reliability.name}",
            f"  History (Depth): {depth}",
            f"  Durability: {qos.durability.name}",
            f"  Lifespan: {qos.lifespan}",
            f"  Deadline: {qos.deadline}",
            f"  Liveliness: {qos.liveliness.name}",
            f"  Liveliness lease duration: {qos.liveliness_lease_duration}",
        ])
