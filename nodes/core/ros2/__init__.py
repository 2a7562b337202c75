"""The ROS 2 wire (docs/ros2.md): every node's public endpoints also speak rmw_zenoh (ROS 2 Jazzy).

A ROS 2 machine with ``RMW_IMPLEMENTATION=rmw_zenoh_cpp`` connected to our router sees our nodes, topics,
services and actions under their ROS names and talks to them in CDR; our msgpack keys are untouched.
``ZENROID_ROS2=0`` (launch files: ``ros2:=false``) turns it off; ``ROS_DOMAIN_ID`` picks the domain.

Hook points (kept tiny on purpose): ``attach(node)`` once per node, and ``Ros2Node.mirror(endpoint)`` once
per endpoint, which returns an object with ``close()`` (or None when the endpoint is not mirrored).
"""

from __future__ import annotations

import heapq
import os
import threading
from typing import Any

import zenoh

from nodes.core.ros2 import client, mirror, names
from nodes.core.ros2.graph import RosGraph

ENV_ENABLE = "ZENROID_ROS2"
ENV_DOMAIN = "ROS_DOMAIN_ID"
_OFF = {"0", "false", "no", "off"}


def enabled() -> bool:
    return os.environ.get(ENV_ENABLE, "1").strip().lower() not in _OFF


def domain_id() -> int:
    """``ROS_DOMAIN_ID`` (default 0); ValueError naming the variable when it is not 0..232."""
    raw = os.environ.get(ENV_DOMAIN, "").strip() or "0"
    try:
        value = int(raw)
    except ValueError:
        raise ValueError(f"{ENV_DOMAIN}={raw!r} is not an integer") from None
    if not 0 <= value <= 232:
        raise ValueError(f"{ENV_DOMAIN}={value} is outside 0..232")
    return value


class _EntityIds:
    """rmw_zenoh's entity ids of one session: unique among the live entities, and a closed entity's id is taken
    again (the smallest first). Zenoh keeps a little memory for every distinct key ever declared, in the node
    and in the router, and the id is part of each liveliness key: fresh ids on every spawn/delete grew both
    without bound."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._next = 0
        self._free: list[int] = []

    def take(self) -> int:
        with self._lock:
            if self._free:
                return heapq.heappop(self._free)
            self._next += 1
            return self._next - 1

    def give_back(self, entity_id: int) -> None:
        with self._lock:
            heapq.heappush(self._free, entity_id)


class _SessionState:
    """What all nodes sharing one Zenoh session share: the graph watcher and rmw_zenoh's entity ids."""

    def __init__(self, session: zenoh.Session, domain: int) -> None:
        self.graph = RosGraph(session, domain)
        self.ids = _EntityIds()
        self.users = 0


_sessions: dict[int, _SessionState] = {}
_sessions_lock = threading.Lock()


class Ros2Node:
    def __init__(self, node: Any, domain: int) -> None:
        self.node = node
        self.session: zenoh.Session = node.session
        self.domain = domain
        self.zid = node.session_id
        self.namespace, self.name = names.split_fqn(node.fully_qualified_name)
        with _sessions_lock:
            state = _sessions.get(id(self.session))
            if state is None:
                state = _sessions[id(self.session)] = _SessionState(self.session, domain)
            state.users += 1
        self._state = state
        self.graph = state.graph
        self.node_id = self.next_entity_id()
        self._token = self.session.liveliness().declare_token(
            names.node_token(domain, self.zid, self.node_id, self.namespace, self.name))
        self._closed = False

    def next_entity_id(self) -> int:
        return self._state.ids.take()

    def release_entity_id(self, entity_id: int) -> None:
        """An entity's token is undeclared: its id may serve the next one."""
        self._state.ids.give_back(entity_id)

    def warn(self, text: str) -> None:
        # throttled per what and where ("ROS 2 wire: bad request on /humanoid/x"), not per reason, and outside
        # the per-call-site budget (the keys are this node's endpoints), so every endpoint's rejections show up
        # even while the node's other endpoints are flooded
        self.node.logger.warn_throttle(5.0, text, key="ros2:" + ": ".join(text.split(": ", 2)[:2])[:300],
                                       per_site=False)

    def mirror(self, endpoint: Any) -> Any | None:
        """The ROS 2 twin of one of our endpoints, or None (internal, wildcard, raw or not expressible)."""
        if self._closed:
            return None
        kind = type(endpoint).__name__
        key = getattr(endpoint, "key", "")
        interface = getattr(endpoint, "msg_type", None) or getattr(endpoint, "srv_type", None) or getattr(
            endpoint, "action_type", None)
        if not key or names.is_internal(key, getattr(interface, "_type", "")):
            return None
        try:
            if kind == "Publisher":
                return mirror.TopicMirror(self, key, endpoint.msg_type._type,
                                          reliable=getattr(endpoint, "reliable", True),
                                          latched=getattr(endpoint, "latched", False),
                                          qos=getattr(endpoint, "ros2_qos", None))
            if kind == "Subscription":
                if endpoint.message.raw or endpoint.msg_type is None or "*" in key:
                    return None
                return mirror.SubscriptionMirror(self, endpoint)
            if kind == "ServiceServer":
                srv = endpoint.srv_type._type
                return mirror.ServiceMirror(self, names.ros_service_name(key), srv, key, endpoint.handle_query)
            if kind == "Client":
                return mirror.service_client(self, endpoint)
            if kind == "ActionServer":
                return mirror.action_server(self, endpoint)
            if kind == "ActionClient":
                return mirror.action_client(self, endpoint)
        except Exception as exc:  # noqa: BLE001 - the ROS 2 wire must never break our own endpoint
            self.warn(f"ROS 2 wire: '{key}' not offered to ROS 2: {type(exc).__name__}: {exc}")
        return None

    def service_client(self, key: str, srv_type: str) -> client.ServiceClient:
        """A client of the ROS 2 service named by our ``key`` (``/`` + key), in CDR on rmw_zenoh's wire."""
        if self._closed:
            raise RuntimeError("the node is closed")
        return client.ServiceClient(self, names.ros_service_name(key), srv_type)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._token.undeclare()
        except Exception:  # noqa: BLE001 - session already closing
            pass
        self.release_entity_id(self.node_id)
        with _sessions_lock:
            self._state.users -= 1
            if self._state.users <= 0:
                _sessions.pop(id(self.session), None)
                self._state.graph.close()


def attach(node: Any) -> Ros2Node | None:
    """The node's presence on the ROS 2 wire, or None when it is off (or misconfigured: logged)."""
    if not enabled():
        return None
    try:
        domain = domain_id()
    except ValueError as exc:
        node.logger.error(f"ROS 2 wire off: {exc}")
        return None
    return Ros2Node(node, domain)
