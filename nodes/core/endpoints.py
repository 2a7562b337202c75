"""Publishers, subscriptions, services and clients: typed messages over Zenoh."""

from __future__ import annotations

import functools
import itertools
import os
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import msgpack
import zenoh

import msgs
from msgs import DecodeError
from nodes.core import intraprocess, memory
from nodes.core.executor import CallbackGroup
from nodes.core.graph import parse_key
from nodes.core.log import truncate
from nodes.core.runtime import NodeRuntime
from nodes.core.session import max_payload_bytes

ENCODING = "application/msgpack"
_ATTACHMENT = struct.Struct("<Q16s")  # sequence number, source id (loss detection, `topic hz`)


def encoding_for(type_name: str) -> zenoh.Encoding:
    return zenoh.Encoding(ENCODING).with_schema(type_name)


def parse_attachment(sample: Any) -> tuple[int, bytes] | None:
    """(sequence, source id) of a sample from a zenroid publisher, else None."""
    att = sample.attachment
    if att is None:
        return None
    raw = att.to_bytes()
    if len(raw) != _ATTACHMENT.size:
        return None
    return _ATTACHMENT.unpack(raw)


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
                 priority: zenoh.Priority | None = None, express: bool = False, latched: bool = False) -> None:
        self.node = node
        self.msg_type = msg_type
        self.key = key
        self.reliable, self.latched = reliable, latched
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
            remote.put(payload, attachment=_ATTACHMENT.pack(seq, self._source))
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
        pub.put(payload, attachment=_ATTACHMENT.pack(next(self._seq), self._source))
        mirror = self._mirror
        if mirror is not None and mirror.active:  # someone subscribes to rmw_zenoh's key: send the CDR twin
            mirror.send(payload)

    def destroy(self) -> None:
        if self._bus is not None:
            self._bus.remove_publisher(self)
        self._token.undeclare()
        if self._mirror is not None:
            self._mirror.close()
        self._pub.undeclare()
        for twin in ("_drop_pub", "_remote_pub", "_remote_drop_pub"):
            if self.__dict__.get(twin) is not None:
                self.__dict__[twin].undeclare()


class Subscription:
    """Messages of ``key`` decoded into ``msg_type`` and handed to ``callback``.

    ``max_rate`` (Hz): wake at most that often and take every message that arrived meanwhile at once.
    Zenoh keeps them in its own ring buffer (the newest ``backlog``), so a fast topic such as a 1 kHz
    ``joint_states`` costs a consumer that only needs 50 updates a second 50 wake-ups, not 1000.

    ``objects=True`` (with ``raw``): in a container, a message another node of the process published as an
    object reaches the callback as that object, built by trusted code and neither encoded nor decoded (the
    hardware frames between a composed simulator and controller manager); from Zenoh, bytes as ``raw``.

    ``pulled=True``: no thread delivers anything. Messages wait in Zenoh's ring buffer (the newest
    ``backlog``) until the owner's thread takes them with ``take_pending()`` or ``wait(timeout)``, and the
    callback runs there. For a thread that holds the GIL for long stretches (the simulator's physics, in
    C++): a delivering thread would wait for the GIL until the physics ends and then hand it back and
    forth; pulling costs no thread hand-off at all.
    """

    def __init__(self, node: NodeRuntime, msg_type: Any, key: str, callback: Callable[..., None], *,
                 inline: bool = False, raw: bool = False, with_key: bool = False, with_source: bool = False,
                 max_rate: float | None = None, backlog: int = 256, pulled: bool = False,
                 objects: bool = False) -> None:
        if not callable(callback):
            raise TypeError(f"the subscription to '{key}' needs a callback")
        self.node = node
        self.msg_type = msg_type
        self.key = key
        self.callback = callback
        self.raw = raw
        self.objects = objects and raw and msg_type is not None
        self.inline = inline
        self.with_key = with_key  # callback(msg, key): for wildcard keys ("*/joint_states")
        # callback(..., source): the sending publisher's 16-byte id from the attachment (None without one),
        # to tell two senders on one key apart. It identifies, it does not authenticate (Zenoh's ACL does).
        self.with_source = with_source
        self.max_payload = max_payload_bytes()   # bigger messages are dropped (logged) before decoding
        if max_rate is not None and not max_rate > 0:
            raise ValueError(f"max_rate must be > 0 Hz, got {max_rate}")
        self.pulled = pulled
        self._wake_pub: Any = None
        self._wake_at: float | None = None   # pulled: monotonic deadline of the wait in progress
        self._watchdog: threading.Condition | None = None   # pulled: wakes the watchdog thread (_watch)
        self._watchdog_idle = False
        self._watching_until: float | None = None   # the deadline the watchdog thread sleeps until
        self.closed = False
        self.group: CallbackGroup | None = None   # on a spinning thread: its callback group (rclpy's)
        self._where = f"subscription '{key}'"   # what an error report says (built once, not per message)
        if pulled:
            self._sub = node.session.declare_subscriber(key, zenoh.handlers.RingChannel(backlog))
        elif max_rate is None:
            self._sub = node.session.declare_subscriber(key, self.handle_sample)
        else:
            self._sub = node.session.declare_subscriber(key, zenoh.handlers.RingChannel(backlog))
            threading.Thread(target=self._drain, args=(1.0 / max_rate,), daemon=True,
                             name=f"sub:{key}").start()
        self._token = node.presence.token("sub", key, msg_type._type if msg_type else "*")
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None
        # In a container: messages of this session's publishers, handed over in-process (intraprocess.py);
        # pulled ones wait here for the owner's thread, as the others wait in Zenoh's buffer.
        self._in_process: deque[tuple[Any, ...]] = deque()
        self._waiting = False   # pulled: the owner's thread is (about to be) blocked in Zenoh's recv
        self._bus = intraprocess.bus_for(node.session)
        if self._bus is not None:
            self._bus.add_subscription(self)

    def wants_payload(self, published_type: Any) -> bool:
        """Does an in-process message of ``published_type`` reach this callback as bytes (or need decoding
        into another class)?"""
        if self.objects and published_type._type == self.msg_type._type:
            return False
        return self.raw or self.msg_type is None or self.msg_type._type != published_type._type

    def take_in_process(self, message: Any, payload: bytes | None, key: str, source: bytes) -> None:
        """A message from a publisher of this session (the publishing thread calls this): the object itself
        when the types agree (zero copy), the publisher's bytes for a raw callback, else decoded from them."""
        if self.closed:
            return
        same_type = message is not None and self.msg_type is not None and message._type == self.msg_type._type
        if same_type and (self.objects or not self.raw):
            value: Any = message
        elif self.raw or self.msg_type is None:
            value = payload
        else:
            try:   # bytes from publish_raw: checked as any payload is (the code that packed them may be wrong)
                value = msgs.decode(self.msg_type, payload, decode_limits())
            except DecodeError as exc:
                self.node.logger.warn_throttle(1.0, f"dropped a message on '{key}': {exc}", key=f"decode:{self.key}")
                return
        args: tuple[Any, ...] = (value, key) if self.with_key else (value,)
        if self.with_source:
            args += (source,)
        if self.pulled:
            self._in_process.append(args)
            if self._waiting:   # the owner is blocked in Zenoh's recv: an empty local message ends it
                self._wake_pub.put(b"", attachment=_WAKE)
        elif self.inline:
            self.node.executor.run_callback(self.callback, *args, where=f"subscription '{self.key}'")
        else:
            self.node.executor.dispatch_in_process(self.callback, *args, where=f"subscription '{self.key}'")

    def _take_in_process(self) -> int:
        count = 0
        while self._in_process:
            args = self._in_process.popleft()
            self.node.executor.run_callback(self.callback, *args, where=f"subscription '{self.key}'")
            count += 1
        return count

    def take_pending(self) -> int:
        """Pulled: handle every message that has arrived, on this thread; returns how many."""
        count = self._take_in_process() if self._in_process else 0
        while (sample := self._sub.try_recv()) is not None:
            if not _is_wake(sample):
                self.handle_sample(sample)
                count += 1
        return count

    def wait(self, timeout: float) -> int:
        """Pulled: block (without the GIL) until a message arrives or ``timeout`` s pass; handles what
        arrived and returns how many (0: timed out, or the subscription was closed).

        Zenoh's channel has no timed receive, so a watchdog thread ends an overdue wait with an empty
        message that only this session sees (``Locality.SESSION_LOCAL``)."""
        if self.closed:
            return 0
        count = self.take_pending()
        if count:
            return count
        self._arm_watchdog(timeout)
        self._waiting = True
        try:
            if self._in_process:   # handed over in-process after take_pending looked
                self._wake_at = None
                return self.take_pending()
            sample = self._sub.recv()
        except zenoh.ZError:
            return 0   # undeclared while waiting (the node is closing)
        finally:
            self._waiting = False
            self._wake_at = None
        if self.closed:
            return 0
        if not _is_wake(sample):
            self.handle_sample(sample)
            count = 1
        return count + self.take_pending()

    def _arm_watchdog(self, timeout: float) -> None:
        if self._wake_pub is None:
            self._wake_pub = self.node.session.declare_publisher(
                self.key, allowed_destination=zenoh.Locality.SESSION_LOCAL)
            self._watchdog = threading.Condition()
            threading.Thread(target=self._watch, daemon=True, name=f"wait:{self.key}").start()
        with self._watchdog:
            self._wake_at = deadline = time.monotonic() + timeout
            # asleep without a deadline, or until a later one (an earlier wait's, longer timeout): wake it to
            # take this one; otherwise it looks at the new deadline when its own comes
            watching = self._watching_until
            if self._watchdog_idle or (watching is not None and deadline < watching):
                self._watchdog.notify()

    def _watch(self) -> None:
        """Wake the owner's ``wait`` once its deadline has passed. It sleeps until the deadline it knows and
        then looks again, never polling: a thread that woke every 10 ms took the GIL from the simulator's
        physics thread 100 times a second (and, on a CPU shared with other processes, waited for that CPU
        before giving it back)."""
        condition = self._watchdog
        try:
            with condition:
                while not (self.closed or self.node.closed):
                    deadline = self._wake_at
                    if deadline is None:
                        self._watchdog_idle = True
                        condition.wait()
                        self._watchdog_idle = False
                        continue
                    remaining = deadline - time.monotonic()
                    if remaining > 0:
                        self._watching_until = deadline
                        condition.wait(remaining)
                        self._watching_until = None
                        continue
                    self._wake_at = None
                    self._wake_pub.put(b"", attachment=_WAKE)
        except zenoh.ZError:
            return   # the session closed

    def _drain(self, period: float) -> None:
        try:
            while True:
                batch = [self._sub.recv()]          # blocks (without the GIL) until something arrives
                while (sample := self._sub.try_recv()) is not None:
                    batch.append(sample)
                with self.node.executor.lock:       # the batch in one go: work queued meanwhile sees all of it
                    for sample in batch:
                        self.handle_sample(sample)
                time.sleep(period)
        except Exception:  # noqa: BLE001 - the subscriber was undeclared: the channel is closed
            return

    def handle_sample(self, sample: zenoh.Sample) -> None:
        size = len(sample.payload)
        if size == 0 and _is_wake(sample):
            return   # another pulled subscription's wake-up on the same key of a shared (container) session
        memory.after_payload(size)
        if size > self.max_payload:   # before copying or decoding anything
            self.node.logger.warn_throttle(
                1.0, f"dropped a message on '{sample.key_expr}': payload: {size} bytes, over the "
                f"{self.max_payload}-byte limit", key=f"size:{self.key}")
            return
        payload = sample.payload.to_bytes()
        if self.raw or self.msg_type is None:
            msg: Any = payload
        else:
            try:
                msg = msgs.decode(self.msg_type, payload, decode_limits())
            except DecodeError as exc:
                self.node.logger.warn_throttle(
                    1.0, f"dropped a message on '{sample.key_expr}': {exc}", key=f"decode:{self.key}")
                return
        args = (msg, str(sample.key_expr)) if self.with_key else (msg,)
        if self.with_source:
            attachment = parse_attachment(sample)
            args += (attachment[1] if attachment is not None else None,)
        if self.inline or self.pulled:   # pulled: the taking thread is the one the owner chose
            self.node.executor.run_callback(self.callback, *args, where=f"subscription '{self.key}'")
        else:
            self.node.executor.dispatch(self.callback, *args, where=self._where, group=self.group)

    def destroy(self) -> None:
        if self._bus is not None:
            self._bus.remove_subscription(self)
        self._token.undeclare()
        if self._mirror is not None:
            self._mirror.close()
        self.closed = True
        if self._wake_pub is None:
            self._sub.undeclare()
            return
        self._wake_pub.put(b"", attachment=_WAKE)   # end a wait in progress: it holds the channel
        with self._watchdog:
            self._watchdog.notify()   # and the watchdog thread's sleep: it sees the subscription closed
        for _ in range(500):
            try:
                self._sub.undeclare()
                break
            except RuntimeError:   # "Already borrowed": the waiting thread has not let go yet
                time.sleep(0.01)
        self._wake_pub.undeclare()


# A pulled subscription's wake-up: an empty message with this attachment (ours are 24 bytes).
_WAKE = b"zenroid-wake"


def _is_wake(sample: zenoh.Sample) -> bool:
    att = sample.attachment
    return len(sample.payload) == 0 and att is not None and att.to_bytes() == _WAKE


# Elements per array in a message from the network (every list: points, names, positions ...; a JointTrajectory
# controller takes up to 100,000 points). msgpack refuses a longer array before building any of it: a 4 MB
# payload could otherwise hold four million tiny elements, a Python object each.
MAX_ARRAY_LENGTH = 100_000


@functools.cache
def decode_limits(max_bytes: int | None = None) -> msgs.Limits:
    """The limits our endpoints decode with (one instance per size, so compiled decoders are shared)."""
    size = max_payload_bytes() if max_bytes is None else max_bytes
    return msgs.Limits(max_message_bytes=size, max_array_length=MAX_ARRAY_LENGTH, max_string_length=size)


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


class ServiceServer:
    """A queryable on ``key``: request map in, response map out (docs/architecture.md, Services and actions)."""

    def __init__(self, node: NodeRuntime, srv_type: Any, key: str, handler: Callable[[Any], Any], *,
                 inline: bool = False) -> None:
        self.node = node
        self.srv_type = srv_type
        self.key = key
        self.handler = handler
        self.inline = inline
        self.group: CallbackGroup | None = None   # on a spinning thread: its callback group (rclpy's)
        self._encoding = encoding_for(srv_type.Response._type)
        self._queryable = node.session.declare_queryable(key, self.handle_query, complete=True)
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
        self._token.undeclare()
        if self._mirror is not None:
            self._mirror.close()
        self._queryable.undeclare()


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


class Client:
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

    def wait_for_service(self, timeout: float = 5.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.service_is_ready():
                return True
            time.sleep(0.05)
        return False

    def destroy(self) -> None:
        self._token.undeclare()
        if self._mirror is not None:
            self._mirror.close()
