"""Mirrors: each public endpoint of a node, also on rmw_zenoh's wire (CDR, ROS names, liveliness tokens).

Our endpoints stay the single implementation: a CDR message or request coming from ROS 2 is converted to
the msgpack map our endpoint expects and handed to it through a stand-in for the Zenoh sample or query,
so validation, callbacks, threading and error replies are exactly those of our own wire. Outgoing msgpack
(which the hot paths pack directly) is converted to CDR only while some Zenoh subscriber matches the data key
(Zenoh's matching status: a ROS 2 subscription, a recorder, a bridge, ``z_sub``). Our own subscription mirrors
listen on a data key only while a foreign ROS 2 publisher announces it (graph.py), so they never count.
"""

from __future__ import annotations

import functools
import itertools
import threading
import time
from typing import Any, Protocol

import msgpack
import zenoh
import zenoh.ext

from msgs import cdr
from msgs.compiled import packb
from nodes.core.ros2 import attachment, names
from nodes.core.ros2.graph import RosGraph
from nodes.core.session import max_payload_bytes
from nodes.core.weak_callback import weak_callback


class MirrorOwner(Protocol):
    """What a mirror needs of the node's ROS 2 presence (``nodes.core.ros2.Ros2Node``)."""

    session: zenoh.Session
    domain: int
    zid: str
    node_id: int
    namespace: str
    name: str
    graph: RosGraph

    def next_entity_id(self) -> int: ...
    def release_entity_id(self, entity_id: int) -> None: ...
    def warn(self, text: str) -> None: ...

_CDR = zenoh.Encoding.APPLICATION_CDR


def _to_cdr(type_name: str, msgpack_payload: bytes) -> bytes:
    return cdr.encode(type_name, msgpack.unpackb(msgpack_payload, raw=False))


def _to_msgpack(type_name: str, cdr_payload: bytes) -> bytes:
    return packb(cdr.decode(type_name, cdr_payload))


class Entity:
    """One liveliness token of ours (and the GID derived from it)."""

    def __init__(self, owner: MirrorOwner, kind: str, ros_name: str, type_name: str,
                 qos: names.Qos = names.DEFAULT_QOS) -> None:
        self.owner = owner
        self.ros_name = ros_name
        self.type_name = type_name
        self.data_key = names.data_key(owner.domain, ros_name, type_name)
        self.entity_id: int | None = owner.next_entity_id()
        key = names.endpoint_token(owner.domain, owner.zid, owner.node_id, self.entity_id, kind,
                                   owner.namespace, owner.name, ros_name, type_name, qos)
        self.gid = attachment.make_gid(key)
        self.token = owner.session.liveliness().declare_token(key)

    def close(self) -> None:
        if self.entity_id is None:
            return   # closed already: its id may be another entity's by now
        self.token.undeclare()
        self.owner.release_entity_id(self.entity_id)
        self.entity_id = None


class TopicMirror:
    """A publisher's CDR twin. ``active`` (read on every publish) follows the publisher's Zenoh matching
    status: True while any subscriber matches the data key, whoever declared it (ROS 2 or plain Zenoh, with
    or without a liveliness token). While a foreign ROS 2 publisher shares the topic our own subscription
    mirrors listen there too and matching cannot tell them apart: then a foreign ROS 2 subscription token
    is needed as well. Latched topics are always active so their last message waits in the cache for late
    subscribers."""

    def __init__(self, owner: MirrorOwner, key: str, type_name: str, *, reliable: bool = True,
                 latched: bool = False, qos: names.Qos | None = None) -> None:
        if qos is None:
            qos = names.LATCHED_QOS if latched else names.Qos(reliable=reliable)
        self.owner = owner
        self.type_name = type_name
        self.entity = Entity(owner, names.PUBLISHER, names.ros_topic_name(key, type_name), type_name, qos)
        session = owner.session
        if latched:
            # rmw_zenoh's transient local: zenoh-ext's advanced publisher with a cache of the history depth
            # that late joiners' advanced subscribers query (sequence numbers, so no timestamping is needed).
            self._pub = zenoh.ext.declare_advanced_publisher(
                session, self.entity.data_key, encoding=_CDR,
                cache=zenoh.ext.CacheConfig(max_samples=max(1, qos.depth)),
                publisher_detection=True, sample_miss_detection=zenoh.ext.MissDetectionConfig())
        else:
            self._pub = session.declare_publisher(
                self.entity.data_key, encoding=_CDR,
                congestion_control=zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP)
        self._seq = itertools.count(1)
        self._latched = latched
        self.active = latched
        if latched:
            return
        self._lock = threading.Lock()
        self._foreign = {names.PUBLISHER: False, names.SUBSCRIPTION: False}  # ROS 2 tokens on our data key
        self._watchers = {kind: functools.partial(self._update, kind) for kind in self._foreign}
        self._matching = self._pub.declare_matching_listener(weak_callback(self._on_matching))
        for kind, watcher in self._watchers.items():
            owner.graph.watch(kind, self.entity.data_key, watcher)
        self._update()  # the listener reports changes only: a subscriber may already be there

    def _on_matching(self, _status: Any) -> None:
        self._update()

    def _update(self, kind: str | None = None, present: bool = False) -> None:
        # Reads the matching status itself rather than trusting an event (the first read and a listener call
        # may interleave); the lock makes whichever runs last also the freshest.
        with self._lock:
            if kind is not None:
                self._foreign[kind] = present
            try:
                matching = bool(self._pub.matching_status.matching)
            except zenoh.ZError:
                matching = False  # undeclared: closing
            self.active = matching and (self._foreign[names.SUBSCRIPTION] or not self._foreign[names.PUBLISHER])

    def send(self, payload: bytes) -> None:
        """Publish the msgpack ``payload`` as CDR (called by the publisher while ``active``)."""
        try:
            data = _to_cdr(self.type_name, payload)
        except (cdr.CdrError, ValueError, msgpack.UnpackException) as exc:
            self.owner.warn(f"ROS 2 wire: not mirrored on {self.entity.ros_name}: {exc}")
            return
        try:
            self._pub.put(data, attachment=attachment.pack(next(self._seq), self.entity.gid))
        except zenoh.ZError:
            pass  # undeclared while a callback was still publishing: shutting down

    def close(self) -> None:
        if not self._latched:
            for kind, watcher in self._watchers.items():
                self.owner.graph.unwatch(kind, self.entity.data_key, watcher)
            self._watchers = {}   # partials of our own method: a cycle that only the cyclic GC would free
            self._matching.undeclare()
        self.entity.close()
        self._pub.undeclare()


class _Payload:
    """What our endpoints read from a Zenoh sample/query payload."""

    def __init__(self, data: bytes) -> None:
        self._data = data

    def to_bytes(self) -> bytes:
        return self._data

    def __len__(self) -> int:
        return len(self._data)


class _Sample:
    def __init__(self, key: str, payload: bytes) -> None:
        self.key_expr = key
        self.payload = _Payload(payload)
        self.attachment = None


class SubscriptionMirror:
    """CDR from ROS 2 publishers on the data key, delivered to our subscription as if it came on our key.

    Its Zenoh subscriber exists only while a foreign ROS 2 publisher's token names the data key (every
    rmw_zenoh or zenoh-ros2-sdk publisher declares one): otherwise it would match our own topic mirrors
    and switch their CDR encoding on for nobody. A plain Zenoh put without a publisher token is not heard.
    """

    def __init__(self, owner: MirrorOwner, subscription: Any) -> None:
        self.owner = owner
        self.target = subscription
        self.type_name = subscription.msg_type._type
        self.qos: names.Qos = getattr(subscription, "ros2_qos", None) or names.DEFAULT_QOS
        self.entity = Entity(owner, names.SUBSCRIPTION, names.ros_topic_name(subscription.key, self.type_name),
                             self.type_name, self.qos)
        self._lock = threading.Lock()
        self._sub: Any = None   # a zenoh Subscriber, or an advanced one for transient local
        self._closed = False
        owner.graph.watch(names.PUBLISHER, self.entity.data_key, self._listen)

    @property
    def listening(self) -> bool:
        return self._sub is not None

    def _listen(self, publishers: bool) -> None:
        with self._lock:
            if self._closed or publishers == (self._sub is not None):
                return
            try:
                if publishers:
                    self._sub = self._declare()
                else:
                    sub, self._sub = self._sub, None
                    sub.undeclare()
            except zenoh.ZError:
                pass  # the session is closing

    def _declare(self) -> Any:
        key, callback = self.entity.data_key, weak_callback(self._on_sample)
        if self.qos.transient_local:
            # rmw_zenoh's transient local: an advanced subscriber, which also takes what the ROS 2 publishers'
            # caches hold (theirs are advanced publishers), those found later included
            return zenoh.ext.declare_advanced_subscriber(
                self.owner.session, key, callback,
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=max(1, self.qos.depth)))
        return self.owner.session.declare_subscriber(key, callback)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        att = attachment.unpack(sample.attachment.to_bytes() if sample.attachment is not None else None)
        if att is not None and attachment.is_ours(att.gid):
            return  # one of our publishers' CDR twins: the message already came on our key
        if len(sample.payload) > self.target.max_payload:   # before converting anything
            self.owner.warn(f"ROS 2 wire: dropped a message on {self.entity.ros_name}: payload: "
                            f"{len(sample.payload)} bytes, over the {self.target.max_payload}-byte limit")
            return
        try:
            payload = _to_msgpack(self.type_name, sample.payload.to_bytes())
        except cdr.CdrError as exc:
            self.owner.warn(f"ROS 2 wire: dropped a message on {self.entity.ros_name}: {exc}")
            return
        self.target.handle_sample(_Sample(self.target.key, payload))

    def close(self) -> None:
        self.owner.graph.unwatch(names.PUBLISHER, self.entity.data_key, self._listen)
        with self._lock:
            self._closed = True
            sub, self._sub = self._sub, None
        self.entity.close()
        if sub is not None:
            sub.undeclare()


class _Query:
    """A ROS 2 request seen by our service/action code as a query on our key with a msgpack payload; its
    answers go back to the ROS 2 client as CDR with the client's sequence number and GID."""

    def __init__(self, owner: MirrorOwner, query: zenoh.Query, key: str, payload: bytes, response_type: str,
                 data_key: str, att: attachment.Attachment) -> None:
        self.owner = owner
        self._query = query
        self.key_expr = key
        self.payload = _Payload(payload)
        self._response_type = response_type
        self._data_key = data_key
        self._att = att

    def reply(self, key: Any, payload: bytes, **_: Any) -> None:
        try:
            data = _to_cdr(self._response_type, payload)
        except (cdr.CdrError, ValueError) as exc:
            self.reply_err(msgpack.packb({"error": f"response not encodable as CDR: {exc}"}))
            return
        self._query.reply(self._data_key, data, encoding=_CDR,
                          attachment=attachment.pack(self._att.sequence, self._att.gid, time.time_ns()))

    def reply_err(self, payload: bytes) -> None:
        try:
            text = str(msgpack.unpackb(payload, raw=False).get("error", ""))
        except Exception:  # noqa: BLE001 - not one of our error maps
            text = bytes(payload).decode(errors="replace")
        self._query.reply_err(text.encode())

    def drop(self) -> None:
        self._query.drop()


class ServiceMirror:
    """A queryable on the data key of a service (or of one of an action's services), answered by our
    endpoint's query handler ``handle(query)``."""

    def __init__(self, owner: MirrorOwner, ros_name: str, srv_type: str, key: str, handle: Any) -> None:
        self.owner = owner
        self.key = key
        self.handle = handle
        self.request_type, self.response_type = f"{srv_type}_Request", f"{srv_type}_Response"
        self.entity = Entity(owner, names.SERVICE, ros_name, srv_type)
        self._queryable = owner.session.declare_queryable(self.entity.data_key, weak_callback(self._on_query), complete=True)

    def _on_query(self, query: zenoh.Query) -> None:
        att = attachment.unpack(query.attachment.to_bytes() if query.attachment is not None else None)
        if att is None:  # rmw_zenoh cannot correlate a reply without it; answer anyway
            att = attachment.Attachment(0, 0, bytes(attachment.GID_SIZE))
        try:
            size, limit = (len(query.payload) if query.payload is not None else 0), max_payload_bytes()
            if size > limit:   # before converting anything
                raise cdr.CdrError(f"request is {size} bytes, over the {limit}-byte limit")
            raw = query.payload.to_bytes() if query.payload is not None else b""
            payload = _to_msgpack(self.request_type, raw)
        except cdr.CdrError as exc:
            self.owner.warn(f"ROS 2 wire: bad request on {self.entity.ros_name}: {exc}")
            query.reply_err(str(exc).encode())
            query.drop()
            return
        self.handle(_Query(self.owner, query, self.key, payload, self.response_type, self.entity.data_key, att))

    def close(self) -> None:
        self.entity.close()
        self._queryable.undeclare()


class Group:
    """Several mirrors that live and die with one endpoint: an action server's three services, or the bare
    tokens of endpoints ROS 2 should see in its graph but never talks to through us (clients, action clients)."""

    def __init__(self, parts: list[Any]) -> None:
        self.parts = parts

    def close(self) -> None:
        for part in self.parts:
            part.close()


def action_server(owner: MirrorOwner, server: Any) -> Group:
    action = server.action_type._type
    parts = [
        ServiceMirror(owner, names.ros_action_service(server.key, "send_goal"), f"{action}_SendGoal",
                      f"{server.key}/send_goal", server.handle_send_goal),
        ServiceMirror(owner, names.ros_action_service(server.key, "cancel_goal"), "action_msgs/srv/CancelGoal",
                      f"{server.key}/cancel_goal", server.handle_cancel_goal),
        ServiceMirror(owner, names.ros_action_service(server.key, "get_result"), f"{action}_GetResult",
                      f"{server.key}/get_result", server.handle_get_result),
    ]
    return Group(parts)


def service_client(owner: MirrorOwner, client: Any) -> Group:
    return Group([Entity(owner, names.CLIENT, names.ros_service_name(client.key), client.srv_type._type)])


def action_client(owner: MirrorOwner, client: Any) -> Group:
    action = client.action_type._type
    key = client.key
    return Group([
        Entity(owner, names.CLIENT, names.ros_action_service(key, "send_goal"), f"{action}_SendGoal"),
        Entity(owner, names.CLIENT, names.ros_action_service(key, "cancel_goal"), "action_msgs/srv/CancelGoal"),
        Entity(owner, names.CLIENT, names.ros_action_service(key, "get_result"), f"{action}_GetResult"),
        Entity(owner, names.SUBSCRIPTION, f"/{key}/_action/feedback", f"{action}_FeedbackMessage"),
        Entity(owner, names.SUBSCRIPTION, f"/{key}/_action/status", "action_msgs/msg/GoalStatusArray"),
    ])
