"""Latched topics (ROS "transient local"): the last messages are also answered as a queryable on the same key.

A publisher of rarely-changing data (``robot_description``, ``tf_static``) publishes normally *and* keeps the
last ``depth`` payloads (one by default, the QoS history depth for rclpy's TRANSIENT_LOCAL); anyone who joins
later runs ``fetch_latched`` (the newest) or ``fetch_latched_history`` (all kept, oldest first), a Zenoh get
on the topic key, then subscribes for changes. Wire format is identical to the topic's (msgpack map of the
message).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any

import zenoh

import msgs
from nodes.core.endpoints import Publisher, encoding_for
from nodes.core.runtime import NodeRuntime
from nodes.core.weak_callback import weak_callback


class LatchedPublisher:
    def __init__(self, node: NodeRuntime, msg_type: Any, key: str, *, depth: int = 1, lifespan: float | None = None,
                 ros2_qos: Any = None) -> None:
        if depth < 1:
            raise ValueError(f"latched publisher on '{key}': depth must be at least 1, got {depth}")
        self.node = node
        self.msg_type = msg_type
        self.key = key
        self.lifespan = lifespan   # s a message is answered for after it was published (None: for ever)
        self._publisher = Publisher(node, msg_type, self.key, latched=True, ros2_qos=ros2_qos)
        self._encoding = encoding_for(msg_type._type)
        # the last ``depth`` (payload, monotonic time published): what a late joiner gets
        self._kept: deque[tuple[bytes, float]] = deque(maxlen=depth)
        self._lock = threading.Lock()
        self._queryable = node.session.declare_queryable(self.key, weak_callback(self._on_query), complete=True)

    def publish(self, msg: Any) -> None:
        if getattr(msg, "_type", None) != self.msg_type._type:
            raise TypeError(f"latched publisher on '{self.key}' sends {self.msg_type._type}, got {type(msg).__name__}")
        payload = msgs.encode(msg)
        with self._lock:
            self._kept.append((payload, time.monotonic()))
        self._publisher.publish_raw(payload)

    def _on_query(self, query: zenoh.Query) -> None:
        # Runs on a Zenoh thread: copies the kept payloads under the lock, replies outside it, oldest first.
        with self._lock:
            kept = list(self._kept)
        if self.lifespan is not None:   # expired ones are not given, as DDS drops them from the history
            now = time.monotonic()
            kept = [(payload, at) for payload, at in kept if now - at <= self.lifespan]
        try:
            for payload, _ in kept:
                query.reply(self.key, payload, encoding=self._encoding)
        finally:
            query.drop()

    def destroy(self) -> None:
        self._queryable.undeclare()
        self._publisher.destroy()


def fetch_latched(session: zenoh.Session, msg_type: Any, key: str, timeout: float = 2.0) -> Any | None:
    """The newest latched message on ``key`` (already resolved), or None when nobody answers in ``timeout`` s.

    Retries until the deadline: a session that has just opened may not know the queryable yet (declarations
    propagate asynchronously), and a query that matches nothing returns at once with no reply.
    Raises ``msgs.DecodeError`` when the answer does not decode as ``msg_type``; returns None once the session
    is closed.
    """
    history = fetch_latched_history(session, msg_type, key, timeout)
    return history[-1] if history else None


def fetch_latched_history(session: zenoh.Session, msg_type: Any, key: str, timeout: float = 2.0) -> list[Any]:
    """Every message the latched publisher on ``key`` keeps, oldest first ([] when nobody answers in
    ``timeout`` s); retries and raises as ``fetch_latched``."""
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return []
        try:
            # no consolidation: the kept messages share one key, and each one is wanted
            replies = session.get(key, timeout=min(remaining, 1.0), target=zenoh.QueryTarget.BEST_MATCHING,
                                  consolidation=zenoh.ConsolidationMode.NONE)
        except zenoh.ZError:
            if session.is_closed():
                return []  # the node is shutting down (Ctrl-C) while a helper thread still asks
            raise
        history = [msgs.decode(msg_type, reply.ok.payload.to_bytes()) for reply in replies if reply.ok is not None]
        if history:
            return history
        time.sleep(min(0.05, max(0.0, deadline - time.monotonic())))


def latest_sample(session: zenoh.Session, key: str, timeout: float = 1.0) -> Any | None:
    """The first answer of a queryable on ``key`` as a raw sample (a latched topic's last message, with its
    key and encoding), or None when nobody answers within ``timeout`` s."""
    for reply in session.get(key, timeout=timeout, target=zenoh.QueryTarget.BEST_MATCHING):
        if reply.ok is not None:
            return reply.ok
    return None
