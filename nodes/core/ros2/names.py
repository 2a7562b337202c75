"""rmw_zenoh's names: ROS names of our keys, DDS type names, data keys, liveliness tokens and QoS strings.

Layout (rmw_zenoh_cpp for ROS 2 Jazzy, ``liveliness_utils.cpp``):

- data key ``<domain>/<ROS name without leading slash>/<DDS type>/<RIHS01 hash>``
- node token ``@ros2_lv/<domain>/<zid>/<node id>/<node id>/NN/<enclave>/<namespace>/<node name>``
- endpoint token ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<MP|MS|SS|SC>/<enclave>/<namespace>/
  <node name>/<ROS name>/<DDS type>/<RIHS01 hash>/<QoS>``, every name with ``/`` mangled to ``%``.
"""

from __future__ import annotations

from dataclasses import dataclass

from msgs.type_hash import rihs01

ADMIN_SPACE = "@ros2_lv"
PUBLISHER, SUBSCRIPTION, SERVICE, CLIENT, NODE = "MP", "MS", "SS", "SC", "NN"
ENCLAVE = "/"  # rcl's default enclave

# Our keys whose ROS name differs from "/" + key: the simulator's clock is ROS' /clock.
_RENAMED = {"sim/clock": "/clock"}
_STATUS_TYPE = "action_msgs/msg/GoalStatusArray"


def mangle(name: str) -> str:
    return name.replace("/", "%")


def demangle(chunk: str) -> str:
    return chunk.replace("%", "/")


def is_internal(key: str, type_name: str = "") -> bool:
    """Endpoints that stay zenroid-only: hardware-interface frames/services, admin spaces and our own
    protocol types (zenroid_msgs, e.g. ``~/get_parameters``, which would shadow ROS' parameter services)."""
    return key.startswith("@") or "hardware" in key.split("/") or type_name.startswith("zenroid_msgs/")


def ros_topic_name(key: str, type_name: str) -> str:
    """The fully qualified ROS name of a topic on our ``key`` carrying ``type_name``.

    Action topics are recognised by their types (``<action>/feedback`` carries ``*_FeedbackMessage``,
    ``<action>/status`` a GoalStatusArray) and get ROS' hidden ``_action/`` level.
    """
    if key in _RENAMED:
        return _RENAMED[key]
    head, _, last = key.rpartition("/")
    if head and ((last == "feedback" and type_name.endswith("_FeedbackMessage"))
                 or (last == "status" and type_name == _STATUS_TYPE)):
        return f"/{head}/_action/{last}"
    return "/" + key


def ros_service_name(key: str) -> str:
    return _RENAMED.get(key, "/" + key)


def ros_action_service(key: str, part: str) -> str:
    """``part`` is send_goal, cancel_goal or get_result."""
    return f"/{key}/_action/{part}"


def dds_type(type_name: str) -> str:
    """"sensor_msgs/msg/JointState" → "sensor_msgs::msg::dds_::JointState_" (services and action parts alike)."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_type(dds: str) -> str:
    """Inverse of ``dds_type``."""
    pkg, kind, _, name = dds.split("::")
    return f"{pkg}/{kind}/{name[:-1]}"


def data_key(domain: int, ros_name: str, type_name: str) -> str:
    return f"{domain}/{ros_name.strip('/')}/{dds_type(type_name)}/{rihs01(type_name)}"


_INFINITE_S = 9223372036   # rmw's infinite duration: 9223372036 s 854775807 ns (elided, as rmw_zenoh does)


@dataclass(frozen=True)
class Qos:
    """The QoS we advertise. rmw_zenoh writes only what differs from its defaults (reliable, volatile,
    keep-last 42, infinite durations, automatic liveliness). Durations in ns, 0 for infinite; ``liveliness``
    is rmw's kind (1 automatic, 3 manual by topic)."""

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10
    keep_all: bool = False
    deadline_ns: int = 0
    lifespan_ns: int = 0
    liveliness: int = 1
    lease_ns: int = 0

    def token(self) -> str:
        reliability = "" if self.reliable else "2"
        durability = "1" if self.transient_local else ""
        history = "2," if self.keep_all else ("," if self.depth == 42 else f",{self.depth}")
        liveliness = "" if self.liveliness == 1 else str(self.liveliness)
        return (f"{reliability}:{durability}:{history}:{_duration(self.deadline_ns)}:"
                f"{_duration(self.lifespan_ns)}:{liveliness},{_duration(self.lease_ns)}")

    @classmethod
    def parse(cls, token: str) -> Qos:
        """The QoS of a liveliness token's last chunk (rmw_zenoh's, ours or zenoh-ros2-sdk's); ValueError when
        it is not one."""
        parts = token.split(":")
        if len(parts) != 6:
            raise ValueError(f"not an rmw_zenoh QoS: {token!r}")
        reliability, durability, history, deadline, lifespan, liveliness = parts
        kind, _, depth = history.partition(",")
        live_kind, _, lease = liveliness.partition(",")
        return cls(reliable=reliability != "2", transient_local=durability == "1",
                   depth=int(depth) if depth else 42, keep_all=kind == "2",
                   deadline_ns=_parse_duration(deadline), lifespan_ns=_parse_duration(lifespan),
                   liveliness=int(live_kind) if live_kind else 1, lease_ns=_parse_duration(lease))


def _duration(ns: int) -> str:
    if ns <= 0:
        return ","
    return f"{ns // 1_000_000_000},{ns % 1_000_000_000}"


def _parse_duration(text: str) -> int:
    sec, _, nsec = text.partition(",")
    if (not sec and not nsec) or int(sec or _INFINITE_S) >= _INFINITE_S:
        return 0
    return int(sec or 0) * 1_000_000_000 + int(nsec or 0)


DEFAULT_QOS = Qos()
LATCHED_QOS = Qos(transient_local=True, depth=1)


def split_fqn(fully_qualified_name: str) -> tuple[str, str]:
    """"/humanoid/controller_manager" → ("/humanoid", "controller_manager"); "/sim" → ("/", "sim")."""
    ns, _, name = fully_qualified_name.rpartition("/")
    return ns or "/", name


def node_token(domain: int, zid: str, node_id: int, namespace: str, name: str) -> str:
    return (f"{ADMIN_SPACE}/{domain}/{zid}/{node_id}/{node_id}/{NODE}/{mangle(ENCLAVE)}/"
            f"{mangle(namespace)}/{mangle(name)}")


def endpoint_token(domain: int, zid: str, node_id: int, entity_id: int, kind: str, namespace: str, node: str,
                   ros_name: str, type_name: str, qos: Qos) -> str:
    return (f"{ADMIN_SPACE}/{domain}/{zid}/{node_id}/{entity_id}/{kind}/{mangle(ENCLAVE)}/{mangle(namespace)}/"
            f"{mangle(node)}/{mangle(ros_name)}/{dds_type(type_name)}/{rihs01(type_name)}/{qos.token()}")


@dataclass(frozen=True)
class Endpoint:
    """One endpoint token seen in the ROS graph."""

    zid: str
    kind: str
    ros_name: str
    type_name: str
    type_hash: str
    data_key: str


def parse_endpoint_token(key: str) -> Endpoint | None:
    parts = str(key).split("/")
    if len(parts) < 13 or parts[0] != ADMIN_SPACE or parts[5] not in (PUBLISHER, SUBSCRIPTION, SERVICE, CLIENT):
        return None
    try:
        type_name = ros_type(parts[10])
    except ValueError:
        return None
    ros_name = demangle(parts[9])
    return Endpoint(parts[2], parts[5], ros_name, type_name, parts[11],
                    f"{parts[1]}/{ros_name.strip('/')}/{parts[10]}/{parts[11]}")
