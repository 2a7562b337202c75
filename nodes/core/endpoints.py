"""Publishers, subscriptions, services and clients: typed messages over Zenoh."""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable
from typing import Any

import msgpack
import zenoh

import msgs
from msgs import DecodeError
from nodes.core import intraprocess, memory
from nodes.core.delivery import (  # noqa: F401 - parse_attachment, MAX_ARRAY_LENGTH: imported from here too
    ATTACHMENT,
    MAX_ARRAY_LENGTH,
    Decoded,
    Delivery,
    Executed,
    decode_limits,
    is_wake,
    parse_attachment,
)
from nodes.core.executor import CallbackGroup
from nodes.core.graph import parse_key
from nodes.core.log import truncate
from nodes.core.runtime import NodeRuntime
from nodes.core.session import max_payload_bytes
from nodes.core.weak_callback import weak_callback

ENCODING = "application/msgpack"


def encoding_for(type_name: str) -> zenoh.Encoding:
    return zenoh.Encoding(ENCODING).with_schema(type_name)


def source_label(source: bytes | None) -> str:
    """A short printable name of a publisher's source id (what log lines show)."""
    return f"source {source[:6].hex()}" if source else "a sender without a zenroid attachment"


class SingleSender:
    """One sender per key (a robot's hardware frames): the first source seen owns the key; another source
    is refused while the owner keeps sending, and takes over once the owner has been silent for
    ``takeover_after`` s (a respawned simulator or controller manager publishes with a new source id).

    Source ids identify publishers, they do not authenticate them: keeping strangers off a key is Zenoh's
    access control. This catches the accidents (a second controller manager, a test client, a replayed bag)
    and the simple forgeries."""

    def __init__(self, takeover_after: float) -> None:
        self.takeover_after = takeover_after
        self.owner: bytes | None = None
        self._seen = False
        self._last = 0.0
        self.refused = 0

    def admit(self, source: bytes | None, now: float) -> bool:
        if not self._seen or source == self.owner or now - self._last > self.takeover_after:
            self.owner, self._seen, self._last = source, True, now
            return True
        self.refused += 1
        return False


class ServiceError(RuntimeError):
    """A service call that returned no response: error reply, timeout or no server."""


class Publisher:
    def __init__(self, node: NodeRuntime, msg_type: Any, key: str, *, reliable: bool = True,
                 priority: zenoh.Priority | None = None, express: bool = False, latched: bool = False,
                 ros2_qos: Any = None) -> None:
        self.node = node
        self.msg_type = msg_type
        self.key = key
        self.reliable, self.latched = reliable, latched
        self.ros2_qos = ros2_qos   # the QoS its ROS 2 twin announces (ros2.names.Qos), None: from the above
        self._priority, self._express = priority, express
        self._pub = node.session.declare_publisher(
            key, encoding=encoding_for(msg_type._type),
            congestion_control=zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP,
            priority=priority, express=express,
        )
        self._source = os.urandom(16)
        self._seq = itertools.count(1)   # next() on a count is atomic under the GIL: no lock per message
        self._token = node.presence.token("pub", key, msg_type._type)
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None
        # In a container (nodes/core/intraprocess.py): the subscriptions of this session that match the key
        # get each message in-process; Zenoh carries it only to the others (REMOTE), so nobody gets it twice.
        self.local_subscriptions: tuple[Subscription, ...] = ()
        self._bus = intraprocess.bus_for(node.session)
        self._remote_pub: Any = None
        if self._bus is not None:
            self._remote_pub = node.session.declare_publisher(
                key, encoding=encoding_for(msg_type._type), allowed_destination=zenoh.Locality.REMOTE,
                congestion_control=zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP,
                priority=priority, express=express)
            self._bus.add_publisher(self)

    def publish(self, msg: Any, *, droppable: bool = False) -> None:
        """Encode and send ``msg`` (a ``msg_type`` instance); ``droppable`` as ``publish_raw``'s."""
        if getattr(msg, "_type", None) != self.msg_type._type:
            raise TypeError(f"publisher on '{self.key}' sends {self.msg_type._type}, got {type(msg).__name__}")
        if self.local_subscriptions:
            self._publish_in_process(msg, None, droppable=droppable)
            return
        self.publish_raw(msgs.encode(msg), droppable=droppable)

    def _droppable_twin(self, *, remote_only: bool = False) -> Any:
        """This key's publisher that drops under congestion (declared on first use); ``remote_only``: the
        container's one, which leaves this session's own subscriptions to the in-process hand-off."""
        name = "_remote_drop_pub" if remote_only else "_drop_pub"
        twin = self.__dict__.get(name)
        if twin is None:
            twin = self.node.session.declare_publisher(
                self.key, encoding=encoding_for(self.msg_type._type), congestion_control=zenoh.CongestionControl.DROP,
                priority=self._priority, express=self._express,
                allowed_destination=zenoh.Locality.REMOTE if remote_only else zenoh.Locality.ANY)
            setattr(self, name, twin)
        return twin

    def _publish_in_process(self, message: Any, payload: bytes | None, *, droppable: bool) -> None:
        """Hand ``message`` (or, from ``publish_raw``, ``payload``) to remote subscribers over Zenoh, encoding it
        only if someone there listens, then to this session's matching subscriptions as the object itself.

        Remote first: a callback here may publish in turn (the controller manager answers a hardware state with
        a command on the same thread), and other processes must see the state before its answer, as they do
        when the two nodes are separate processes."""
        if self.node.closed:
            return
        local = self.local_subscriptions
        seq = next(self._seq)
        mirror = self._mirror
        mirrored = mirror is not None and mirror.active
        remote = self._droppable_twin(remote_only=True) if droppable and self.reliable else self._remote_pub
        if mirrored or remote.matching_status.matching:
            if payload is None:
                payload = msgs.encode(message)
            remote.put(payload, attachment=ATTACHMENT.pack(seq, self._source))
            if mirrored:
                mirror.send(payload)
        # else nobody outside this process listens: not even encoded
        if payload is None and any(s.wants_payload(self.msg_type) for s in local):
            payload = msgs.encode(message)   # once for every subscriber that takes bytes
        for subscription in local:
            subscription.take_in_process(message, payload, self.key, self._source)

    @property
    def has_subscribers(self) -> bool:
        """True when at least one subscriber matches this key or its ROS 2 wire twin (skip costly messages
        nobody reads)."""
        mirror = self._mirror
        if mirror is not None and mirror.active:
            return True
        if self.local_subscriptions:
            return True
        try:
            return bool(self._pub.matching_status.matching)
        except Exception:  # noqa: BLE001 - undeclared or closed: nobody to send to
            return False

    def publish_raw(self, payload: bytes, *, droppable: bool = False) -> None:
        """Send an encoded message. ``droppable=True``: drop it rather than wait when the link is congested
        (a periodic stream whose next message supersedes this one), whatever the publisher's reliability."""
        if self.node.closed:
            return  # a callback still running while the node shuts down: nothing to send to
        if self.local_subscriptions:
            self._publish_in_process(None, payload, droppable=droppable)
            return
        pub = self._pub
        if droppable and self.reliable:
            pub = self._droppable_twin()
        pub.put(payload, attachment=ATTACHMENT.pack(next(self._seq), self._source))
        mirror = self._mirror
        if mirror is not None and mirror.active:  # someone subscribes to rmw_zenoh's key: send the CDR twin
            mirror.send(payload)

    def destroy(self) -> None:
        if self._bus is not None:
            self._bus.remove_publisher(self)
        self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None
            mirror.close()
        self._pub.undeclare()
        for twin in ("_drop_pub", "_remote_pub", "_remote_drop_pub"):
            if self.__dict__.get(twin) is not None:
                self.__dict__[twin].undeclare()


class Subscription:
    """Messages of ``key`` handed to ``callback``: ``delivery`` says where and when it runs (default
    ``Executed()``: by the node's executor), ``message`` what it gets (default ``Decoded()``: the message as
    ``msg_type``); both are objects of ``nodes/core/delivery.py``, one pair per subscription."""

    def __init__(self, node: NodeRuntime, msg_type: Any, key: str, callback: Callable[..., None], *,
                 delivery: Delivery | None = None, message: Decoded | None = None, ros2_qos: Any = None) -> None:
        if not callable(callback):
            raise TypeError(f"the subscription to '{key}' needs a callback")
        delivery = Executed() if delivery is None else delivery
        message = Decoded() if message is None else message
        if not isinstance(delivery, Delivery):
            raise TypeError(f"subscription '{key}': delivery must be Executed(), Inline(), Batched(...) or "
                            f"Pulled(...) from nodes.core.delivery, got {delivery!r}")
        if not isinstance(message, Decoded):
            raise TypeError(f"subscription '{key}': message must be Decoded() or Raw() from "
                            f"nodes.core.delivery, got {message!r}")
        if msg_type is None and not message.raw:
            raise TypeError(f"subscription '{key}' has no message type: its callback takes bytes "
                            "(message=Raw())")
        self.node = node
        self.msg_type = msg_type
        self.key = key
        self.callback = callback
        self.delivery = delivery
        self.message = message
        self.max_payload = max_payload_bytes()   # bigger messages are dropped (logged) before decoding
        self.closed = False
        self.group: CallbackGroup | None = None   # on a spinning thread: its callback group (rclpy's)
        self.ros2_qos = ros2_qos   # the QoS its ROS 2 twin announces (ros2.names.Qos), None: the default
        self._arguments = message.sample_arguments
        delivery.open(self)
        self._run = delivery.run
        delivery.declare(self)   # last: Zenoh may hand over a sample before this call returns
        self._token = node.presence.token("sub", key, msg_type._type if msg_type else "*")
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None
        # In a container: messages of this session's publishers, handed over in-process (intraprocess.py)
        self._bus = intraprocess.bus_for(node.session)
        if self._bus is not None:
            self._bus.add_subscription(self)

    @property
    def raw(self) -> bool:
        """Does the callback take bytes (no ROS 2 twin is offered for it)?"""
        return self.message.raw

    def wants_payload(self, published_type: Any) -> bool:
        """Does an in-process message of ``published_type`` reach this callback as bytes (or need decoding
        into another class)?"""
        return self.message.wants_payload(self, published_type)

    def take_in_process(self, message: Any, payload: bytes | None, key: str, source: bytes) -> None:
        """A message from a publisher of this session (the publishing thread calls this)."""
        if self.closed:
            return
        args = self.message.object_arguments(self, message, payload, key, source)
        if args is not None:
            self.delivery.run_in_process(*args)

    def take_pending(self) -> int:
        """``Pulled``: handle every message that has arrived, on this thread; returns how many."""
        return self.delivery.take_pending()

    def wait(self, timeout: float) -> int:
        """``Pulled``: block until a message arrives or ``timeout`` s pass, handle what arrived; how many."""
        return self.delivery.wait(timeout)

    def handle_sample(self, sample: zenoh.Sample) -> None:
        # every subscription's hot path: the checks of arguments_of, inline rather than one call more
        size = len(sample.payload)
        if size == 0 and is_wake(sample):
            return   # a pulled subscription's wake-up on the same key of a shared (container) session
        memory.after_payload(size)
        if size > self.max_payload:   # before copying or decoding anything
            self._refuse_oversized(sample, size)
            return
        args = self._arguments(self, sample)
        if args is not None:
            self._run(*args)

    def arguments_of(self, sample: zenoh.Sample) -> tuple[Any, ...] | None:
        """What the callback gets for ``sample``; None for a wake-up or a refused message (logged)."""
        size = len(sample.payload)
        if size == 0 and is_wake(sample):
            return None
        memory.after_payload(size)
        if size > self.max_payload:
            self._refuse_oversized(sample, size)
            return None
        return self._arguments(self, sample)

    def _refuse_oversized(self, sample: zenoh.Sample, size: int) -> None:
        self.node.logger.warn_throttle(
            1.0, f"dropped a message on '{sample.key_expr}': payload: {size} bytes, over the "
            f"{self.max_payload}-byte limit", key=f"size:{self.key}")

    def destroy(self) -> None:
        if self._bus is not None:
            self._bus.remove_subscription(self)
        self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None   # it refers back to us: no cycle left behind
            mirror.close()
        self.closed = True
        self.delivery.close()
        # The owner often holds this subscription and gave it one of its own methods: let go of that method,
        # so the owner is freed by reference counting once dropped, not at the cyclic GC's next full
        # collection (which a process with many long-lived objects runs rarely).
        self.callback = self.delivery.callback = _closed_callback
        # and of what the delivery bound it into (a partial, a bound method of its own)
        self._run = self.delivery.run = self.delivery.run_in_process = _closed_callback



def _closed_callback(*_: Any) -> None:
    """A destroyed subscription's callback (a message already on its way ends here)."""


def _closed_handler(_request: Any) -> Any:
    raise RuntimeError("the service was destroyed")


def _error_payload(reason: str) -> bytes:
    return msgpack.packb({"error": truncate(reason)}, use_bin_type=True)


_EMPTY_MAP = msgpack.packb({})


def decode_request(node: NodeRuntime, query: zenoh.Query, cls: Any, what: str,
                   max_payload: int | None = None) -> Any | None:
    """The query's request as ``cls``; on a bad or oversized payload, answer ``reply_err`` naming the field
    and return None. The size is checked before the payload is copied or decoded."""
    limit = max_payload_bytes() if max_payload is None else max_payload
    size = len(query.payload) if query.payload is not None else 0
    memory.after_payload(size)
    try:
        if size > limit:
            raise DecodeError(cls._type, "", f"request is {size} bytes, over the {limit}-byte limit")
        payload = query.payload.to_bytes() if query.payload is not None else b""
        # no payload: a request without fields
        return msgs.decode(cls, payload or _EMPTY_MAP, decode_limits(limit))
    except DecodeError as exc:
        node.logger.warn_throttle(1.0, f"{what}: bad request: {exc}", key=f"bad request:{what}")
        query.reply_err(_error_payload(str(exc)))
        query.drop()
        return None


class Deferred:
    """A service response that comes later: a handler returns one and, from any thread, calls ``resolve``
    with the response (or ``fail`` with an exception) when it has it. The request is held until then, so a
    handler can hand slow work to another thread without keeping its node's callbacks waiting."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._outcome: tuple[Any, BaseException | None] | None = None
        self._done: Callable[[Any, BaseException | None], None] | None = None

    def resolve(self, response: Any) -> None:
        self._finish(response, None)

    def fail(self, error: BaseException) -> None:
        self._finish(None, error)

    def _finish(self, response: Any, error: BaseException | None) -> None:
        with self._lock:
            if self._outcome is not None:
                return   # answered once
            self._outcome = (response, error)
            done = self._done
        if done is not None:
            done(response, error)

    @property
    def outcome(self) -> tuple[Any, BaseException | None] | None:
        """``(response, error)`` once resolved or failed, else None."""
        return self._outcome

    def on_done(self, callback: Callable[[Any, BaseException | None], None]) -> None:
        with self._lock:
            self._done = callback
            outcome = self._outcome
        if outcome is not None:
            callback(*outcome)


class ServiceServer:
    """A queryable on ``key``: request map in, response map out (docs/architecture.md, Services and actions).
    A handler may return a ``Deferred`` and answer later. ``ros2_only``: served on the ROS 2 wire alone (no
    queryable or graph token on our key, which another service of ours may use)."""

    def __init__(self, node: NodeRuntime, srv_type: Any, key: str, handler: Callable[[Any], Any], *,
                 inline: bool = False, ros2_only: bool = False) -> None:
        self.node = node
        self.srv_type = srv_type
        self.key = key
        self.handler = handler
        self.inline = inline
        self.group: CallbackGroup | None = None   # on a spinning thread: its callback group (rclpy's)
        self._encoding = encoding_for(srv_type.Response._type)
        self._queryable: Any = None
        self._token: Any = None
        if not ros2_only:
            self._queryable = node.session.declare_queryable(key, weak_callback(self.handle_query), complete=True)
            self._token = node.presence.token("srv", key, srv_type._type)
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None

    def handle_query(self, query: zenoh.Query) -> None:
        request = decode_request(self.node, query, self.srv_type.Request, f"service '{self.key}'")
        if request is None:
            return
        if self.inline:
            self._serve(query, request)
        else:
            self.node.executor.dispatch(self._serve, query, request, where=f"service '{self.key}'", group=self.group)

    def _serve(self, query: zenoh.Query, request: Any) -> None:
        try:
            response = self.handler(request)
        except Exception as exc:  # noqa: BLE001 - a failing handler answers with an error, the node lives on
            self._answer(query, None, exc)
            return
        if isinstance(response, Deferred):
            response.on_done(lambda result, error: self._answer(query, result, error))
            return
        self._answer(query, response, None)

    def _answer(self, query: zenoh.Query, response: Any, error: BaseException | None) -> None:
        try:
            if error is not None:
                raise error
            if getattr(response, "_type", None) != self.srv_type.Response._type:
                raise TypeError(f"handler returned {type(response).__name__}, expected {self.srv_type.Response._type}")
            query.reply(self.key, msgs.encode(response), encoding=self._encoding)
        except Exception as exc:  # noqa: BLE001 - a failing handler answers with an error, the node lives on
            reason = f"{type(exc).__name__}: {exc}"
            self.node.logger.error(f"service '{self.key}' failed: {reason}")
            query.reply_err(_error_payload(reason))
        finally:
            # a large request's garbage exists only now that its handler (maybe on another thread) is done
            memory.after_payload(len(query.payload) if query.payload is not None else 0)
            query.drop()

    def destroy(self) -> None:
        if self._token is not None:
            self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None
            mirror.close()
        if self._queryable is not None:
            self._queryable.undeclare()
        self._queryable = None   # zenoh-python may keep its callback, our bound method, while it exists
        self.handler = _closed_handler   # the owner's method: see Subscription.destroy


def call_raw(session: zenoh.Session, key: str, payload: bytes, timeout: float) -> bytes:
    """One request; returns the first ok reply's payload or raises ServiceError.

    A query that finds no server returns at once; it is retried until ``timeout`` because a fresh
    session needs a few milliseconds before routes to existing queryables form, and a server may be
    starting (the ros2_control spawner race).
    """
    deadline = time.monotonic() + timeout
    while True:
        remaining = max(0.01, deadline - time.monotonic())
        replies = session.get(key, payload=payload, encoding=zenoh.Encoding(ENCODING), timeout=remaining,
                              target=zenoh.QueryTarget.BEST_MATCHING)
        for reply in replies:
            if reply.ok is not None:
                return reply.ok.payload.to_bytes()
            err = reply.err.payload.to_bytes()
            try:
                reason = msgpack.unpackb(err, raw=False).get("error", err)
            except Exception:  # noqa: BLE001 - a non-zenroid server may send any bytes
                reason = err.decode(errors="replace")
            raise ServiceError(f"service '{key}' returned an error: {reason}")
        if time.monotonic() >= deadline - 0.02:
            break
        time.sleep(0.02)
    raise ServiceError(f"no response from service '{key}' within {timeout:g} s (is its server running?)")


class _WaitsForService:
    """``wait_for_service`` polling the client's own ``service_is_ready``."""

    def service_is_ready(self) -> bool:
        raise NotImplementedError

    def wait_for_service(self, timeout: float = 5.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.service_is_ready():
                return True
            time.sleep(0.05)
        return False


class Client(_WaitsForService):
    def __init__(self, node: NodeRuntime, srv_type: Any, key: str) -> None:
        self.node = node
        self.srv_type = srv_type
        self.key = key
        self._token = node.presence.token("cli", key, srv_type._type)
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None

    def call(self, request: Any | None = None, timeout: float = 2.0) -> Any:
        """Send ``request`` (default: an empty Request) and return the decoded Response."""
        request = self.srv_type.Request() if request is None else request
        data = call_raw(self.node.session, self.key, msgs.encode(request), timeout)
        try:
            return msgs.decode(self.srv_type.Response, data)
        except DecodeError as exc:
            raise ServiceError(f"service '{self.key}' sent a bad response: {exc}") from None

    def service_is_ready(self) -> bool:
        replies = self.node.session.liveliness().get("@graph/srv/**", timeout=0.5)
        for reply in replies:
            if reply.ok is not None:
                entry = parse_key(str(reply.ok.key_expr))
                if entry and entry.name == self.key:
                    return True
        return False

    def destroy(self) -> None:
        self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None
            mirror.close()


class Ros2Client(_WaitsForService):
    """A client of a service on the ROS 2 wire (CDR, rmw_zenoh): ROS 2 nodes' services and the ones our
    nodes offer there only. Same calls as ``Client``."""

    def __init__(self, node: NodeRuntime, srv_type: Any, key: str) -> None:
        self.node = node
        self.srv_type = srv_type
        self.key = key
        self._wire = node.presence.ros2_client(key, srv_type._type)

    def call(self, request: Any | None = None, timeout: float = 2.0) -> Any:
        request = self.srv_type.Request() if request is None else request
        try:
            data = self._wire.call_msgpack(msgs.encode(request), timeout)
        except RuntimeError as exc:
            raise ServiceError(str(exc)) from None
        try:
            return msgs.decode(self.srv_type.Response, data)
        except DecodeError as exc:
            raise ServiceError(f"service '/{self.key}' sent a bad response: {exc}") from None

    def service_is_ready(self) -> bool:
        return self._wire.server_is_ready()

    def destroy(self) -> None:
        self._wire.close()
