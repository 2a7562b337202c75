"""Who publishes and subscribes a ROS topic, with each endpoint's QoS: what ``ros2 topic info -v`` reads from
rmw_zenoh's liveliness tokens (``@ros2_lv``), ours and those of real ROS 2 nodes alike, and zenroid's
endpoints that are not on the ROS 2 wire (``ZENROID_ROS2=0``, internal keys) from our own graph, with no QoS."""

from __future__ import annotations

import time
from dataclasses import dataclass

import zenoh

from nodes.core import graph
from nodes.core.ros2 import attachment, names


@dataclass(frozen=True)
class EndpointInfo:
    kind: str           # names.PUBLISHER or names.SUBSCRIPTION
    zid: str            # the Zenoh session that declared it
    namespace: str
    node: str
    ros_name: str
    type_name: str
    type_hash: str      # RIHS01_<hex>; "" when unknown (an endpoint only our graph knows)
    gid: bytes
    qos: names.Qos | None   # None: unknown (an endpoint only our graph knows)


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


def endpoints_of(session: zenoh.Session, key: str, publishers: bool, *, domain: int | None) -> list[EndpointInfo]:
    """The publishers (or subscriptions) of our ``key``: every one the ROS 2 wire announces on ``domain``
    (None: the wire is off), and zenroid's that only our graph knows, sorted by namespace and node."""
    found: list[EndpointInfo] = []
    on_wire: set[tuple[str, str]] = set()   # (session id, node) of those the wire told about
    if domain is not None:
        wanted = names.PUBLISHER if publishers else names.SUBSCRIPTION
        for info in topic_endpoints(session, domain, "/" + key.strip("/")):
            if info.kind == wanted:
                on_wire.add((info.zid, "/" + "/".join(p for p in (info.namespace.strip("/"), info.node) if p)))
                found.append(info)
    kind = "pub" if publishers else "sub"
    for entry in graph.snapshot(session, 0.3):
        if entry.kind != kind or entry.name != key or (entry.session_id, entry.node) in on_wire:
            continue
        namespace, _, node = entry.node.rpartition("/")
        token = graph.endpoint_key(entry.kind, entry.session_id, entry.node, entry.name, entry.type_name)
        found.append(EndpointInfo(names.PUBLISHER if publishers else names.SUBSCRIPTION, entry.session_id,
                                  namespace or "/", node, "/" + key.strip("/"), entry.type_name, "",
                                  attachment.make_gid(token), None))
    return sorted(found, key=lambda i: (i.namespace, i.node))
