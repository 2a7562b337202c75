"""Which publishers and subscriptions a topic has, and which publishers are alive (rclpy's matched events and
liveliness QoS), told by Zenoh liveliness.

Every endpoint's graph token (``graph.py``) lives as long as the endpoint: it goes when the endpoint is
destroyed, and when its process dies (the router drops a dead session's tokens); with the ROS 2 wire on, so
do the rmw_zenoh tokens of ROS 2 machines' endpoints (``@ros2_lv``). A publisher whose
liveliness is asserted by hand (MANUAL_BY_TOPIC) also declares ``@liveliness/manual/<key>/<session id>/<node>``
and puts an empty sample on ``@liveliness/assert/<key>/<session id>/<node>`` when it asserts (at most a few
times a lease). Writers are named ``(session id, node)`` on both.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any
from urllib.parse import quote, unquote

import zenoh

from nodes.core import graph, ros2
from nodes.core.ros2 import endpoint_info
from nodes.core.ros2 import names as ros2_names
from nodes.core.weak_callback import weak_callback

MANUAL = "@liveliness/manual"
ASSERT = "@liveliness/assert"

Writer = tuple[str, str]   # (session id, node)


def _chunk(text: str) -> str:
    return quote(text, safe="") or "%00"


def _writer_of(key: str) -> Writer | None:
    parts = str(key).split("/")
    if len(parts) != 5:
        return None
    return parts[3], unquote(parts[4])


class ManualAssertion:
    """A MANUAL_BY_TOPIC publisher's side: announced as manual, and its assertions sent, no more often than
    ``min_interval`` s."""

    def __init__(self, session: zenoh.Session, key: str, session_id: str, node: str, min_interval: float) -> None:
        tail = f"{_chunk(key)}/{session_id}/{_chunk(node)}"
        self._token = session.liveliness().declare_token(f"{MANUAL}/{tail}")
        self._pub = session.declare_publisher(f"{ASSERT}/{tail}")
        self._min_interval = min_interval
        self._last = float("-inf")

    def assert_liveliness(self, now: float) -> None:
        if now - self._last < self._min_interval:
            return
        self._last = now
        try:
            self._pub.put(b"")
        except zenoh.ZError:
            pass   # closing

    def close(self) -> None:
        for entity in (self._pub, self._token):
            try:
                entity.undeclare()
            except Exception:  # noqa: BLE001 - the session may already be closing
                pass


class TopicPeers:
    """``on_change(peer, present)`` for every publisher (``kind`` "pub") or subscription ("sub") of ``key``
    that appears or goes away, those already there included; ``peer`` is ``(session id, node)``. zenroid's
    endpoints tell through their graph tokens, and, with the ROS 2 wire on, ROS 2 machines' endpoints through
    their rmw_zenoh tokens on the topic's ROS name and type (our twins are there too, under the same session
    id and node: a peer counts once, whichever tokens tell about it). Callbacks run on Zenoh threads."""

    def __init__(self, session: zenoh.Session, kind: str, key: str, type_name: str,
                 on_change: Callable[[Writer, bool], None]) -> None:
        self._on_change = on_change
        self._sources: dict[Writer, set[str]] = {}
        self._lock = threading.Lock()
        self._watches: list[Any] = [graph.EndpointWatch(session, kind, key, weak_callback(self._graph))]
        if ros2.enabled() and type_name and type_name != "*":
            try:
                domain = ros2.domain_id()
            except ValueError:
                return   # said by the node's ROS 2 presence already
            wire = ros2_names.PUBLISHER if kind == "pub" else ros2_names.SUBSCRIPTION
            name = ros2_names.mangle(ros2_names.ros_topic_name(key, type_name))
            self._watches.append(session.liveliness().declare_subscriber(
                f"{ros2_names.ADMIN_SPACE}/{domain}/*/*/*/{wire}/*/*/*/{name}/{ros2_names.dds_type(type_name)}/*/*",
                weak_callback(self._ros2), history=True))

    def _graph(self, entry: graph.GraphEntry, present: bool) -> None:
        self._update((entry.session_id, entry.node), "graph", present)

    def _ros2(self, sample: zenoh.Sample) -> None:
        info = endpoint_info.parse(str(sample.key_expr))
        if info is not None:
            fqn = "/" + "/".join(p for p in (info.namespace.strip("/"), info.node) if p)
            self._update((info.zid, fqn), str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    def _update(self, peer: Writer, source: str, present: bool) -> None:
        with self._lock:
            sources = self._sources.setdefault(peer, set())
            was = bool(sources)
            (sources.add if present else sources.discard)(source)
            now = bool(sources)
            if not now:
                del self._sources[peer]
        if now != was:
            self._on_change(peer, now)

    def close(self) -> None:
        for watch in self._watches:
            try:
                watch.close() if hasattr(watch, "close") else watch.undeclare()
            except Exception:  # noqa: BLE001 - the session may already be closing
                pass


class PublisherLiveliness:
    """A subscription's side: ``on_writer(writer, present)`` for every publisher of ``key`` that appears or
    goes (those already there included, ROS 2 machines' too: ``TopicPeers``), ``on_manual(writer)`` for each
    that asserts by hand and ``on_assert(writer)`` for each of its assertions. Callbacks run on Zenoh
    threads."""

    def __init__(self, session: zenoh.Session, key: str, type_name: str, on_writer: Callable[[Writer, bool], None],
                 on_manual: Callable[[Writer], None], on_assert: Callable[[Writer], None]) -> None:
        self._on_writer, self._on_manual, self._on_assert = on_writer, on_manual, on_assert
        enc = _chunk(key)
        self._publishers = TopicPeers(session, "pub", key, type_name, weak_callback(self._publisher))
        self._subs = [
            session.liveliness().declare_subscriber(f"{MANUAL}/{enc}/*/*", weak_callback(self._manual_sample),
                                                    history=True),
            session.declare_subscriber(f"{ASSERT}/{enc}/*/*", weak_callback(self._assert_sample)),
        ]

    def _publisher(self, writer: Writer, present: bool) -> None:
        self._on_writer(writer, present)

    def _manual_sample(self, sample: zenoh.Sample) -> None:
        writer = _writer_of(str(sample.key_expr))
        if writer is not None and sample.kind == zenoh.SampleKind.PUT:
            self._on_manual(writer)

    def _assert_sample(self, sample: zenoh.Sample) -> None:
        writer = _writer_of(str(sample.key_expr))
        if writer is not None:
            self._on_assert(writer)

    def close(self) -> None:
        self._publishers.close()
        for sub in self._subs:
            try:
                sub.undeclare()
            except Exception:  # noqa: BLE001 - the session may already be closing
                pass
