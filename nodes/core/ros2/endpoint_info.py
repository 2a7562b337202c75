"""Who publishes and subscribes a ROS topic, with each endpoint's QoS: what ``ros2 topic info -v`` reads from
rmw_zenoh's liveliness tokens (``@ros2_lv``), ours and those of real ROS 2 nodes alike."""

from __future__ import annotations

import time
from dataclasses import dataclass

import zenoh

from nodes.core.ros2 import attachment, names


@dataclass(frozen=True)
class EndpointInfo:
    kind: str           # names.PUBLISHER or names.SUBSCRIPTION
    zid: str            # the Zenoh session that declared it
    namespace: str
    node: str
    ros_name: str
    type_name: str
    type_hash: str      # RIHS01_<hex>
    gid: bytes
    qos: names.Qos


def parse(key: str) -> EndpointInfo | None:
    """The topic endpoint a token key stands for, None for any other key (or a malformed one)."""
    parts = str(key).split("/")
    if len(parts) < 13 or parts[0] != names.ADMIN_SPACE or parts[5] not in (names.PUBLISHER, names.SUBSCRIPTION):
        return None
    try:
        type_name = names.ros_type(parts[10])
        qos = names.Qos.parse(parts[12])
    except ValueError:
        return None
    return EndpointInfo(parts[5], parts[2], names.demangle(parts[7]), names.demangle(parts[8]),
                        names.demangle(parts[9]), type_name, parts[11], attachment.make_gid(str(key)), qos)


def topic_endpoints(session: zenoh.Session, domain: int, ros_name: str, timeout: float = 1.0) -> list[EndpointInfo]:
    """Every publisher and subscription of ``ros_name`` announced on ``domain`` now.

    One liveliness query may answer only part of the router's tokens (as ``graph.snapshot`` finds), so it is
    asked again until two answers in a row agree (or ``timeout`` passes)."""
    deadline = time.monotonic() + timeout
    previous: set[str] | None = None
    while True:
        keys = {str(reply.ok.key_expr) for reply in session.liveliness().get(
            f"{names.ADMIN_SPACE}/{domain}/**", timeout=max(0.05, deadline - time.monotonic())) if reply.ok is not None}
        if (keys and keys == previous) or time.monotonic() >= deadline:
            break
        previous = keys
        time.sleep(0.03)
    found = [info for info in map(parse, sorted(keys)) if info is not None and info.ros_name == ros_name]
    return found
