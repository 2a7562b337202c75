"""In-process hand-off between the nodes of one container (``nodes/core/container.py``), as rclcpp's
intra-process communication does for composed nodes.

The nodes of a container share one Zenoh session, and the container switches this bus on for it. Then a
publisher hands each message to the subscriptions of the same session whose key matches, as the object it
was given (a message, or the bytes of ``publish_raw``): no encoding, no copy, no Zenoh hop, on the
publishing thread. The same message still goes out on Zenoh for everyone else, through a publisher
declared with ``allowed_destination=Locality.REMOTE``, so the session's own subscriptions do not get it
twice; when no remote subscriber matches (Zenoh's matching status) and no ROS 2 twin listens, it is not
even encoded.

A session without the bus (every node in its own process) behaves exactly as before: nothing here runs.
"""

from __future__ import annotations

import threading
from typing import Any, Protocol

import zenoh


class LocalEndpoint(Protocol):
    key: str


def keys_match(subscribed: str, published: str) -> bool:
    """Does a subscription to ``subscribed`` (wildcards allowed) receive what is put on ``published``?"""
    return zenoh.KeyExpr(subscribed).intersects(zenoh.KeyExpr(published))


class IntraProcessBus:
    """The publishers and subscriptions of one session, each publisher knowing its matching subscriptions.

    A publisher reads its ``local_subscriptions`` (a tuple, replaced whole under the lock) on every message
    without locking: the hot path costs one attribute read when nothing in-process listens."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._publishers: list[Any] = []
        self._subscriptions: list[Any] = []

    def add_publisher(self, publisher: Any) -> None:
        with self._lock:
            self._publishers.append(publisher)
            publisher.local_subscriptions = tuple(s for s in self._subscriptions if keys_match(s.key, publisher.key))

    def remove_publisher(self, publisher: Any) -> None:
        with self._lock:
            if publisher in self._publishers:
                self._publishers.remove(publisher)
            publisher.local_subscriptions = ()

    def add_subscription(self, subscription: Any) -> None:
        with self._lock:
            self._subscriptions.append(subscription)
            for publisher in self._publishers:
                if keys_match(subscription.key, publisher.key):
                    publisher.local_subscriptions = (*publisher.local_subscriptions, subscription)

    def remove_subscription(self, subscription: Any) -> None:
        with self._lock:
            if subscription in self._subscriptions:
                self._subscriptions.remove(subscription)
            for publisher in self._publishers:
                if subscription in publisher.local_subscriptions:
                    publisher.local_subscriptions = tuple(
                        s for s in publisher.local_subscriptions if s is not subscription)


# One bus per session that a container shares; keyed by id(): a Zenoh session takes no attributes, and a
# container's session lives as long as its process.
_buses: dict[int, IntraProcessBus] = {}
_buses_lock = threading.Lock()


def enable(session: zenoh.Session) -> IntraProcessBus:
    """Switch in-process hand-off on for every node that will use ``session`` (before they are built)."""
    with _buses_lock:
        return _buses.setdefault(id(session), IntraProcessBus())


def disable(session: zenoh.Session) -> None:
    with _buses_lock:
        _buses.pop(id(session), None)


def bus_for(session: zenoh.Session) -> IntraProcessBus | None:
    return _buses.get(id(session))
