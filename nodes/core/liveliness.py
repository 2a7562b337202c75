"""Which publishers of a key are alive (rclpy's liveliness QoS), told by Zenoh liveliness.

Every publisher's graph token (``graph.py``) lives as long as the publisher: it goes when the publisher is
destroyed, and when its process dies (the router drops a dead session's tokens). A publisher whose
liveliness is asserted by hand (MANUAL_BY_TOPIC) also declares ``@liveliness/manual/<key>/<session id>/<node>``
and puts an empty sample on ``@liveliness/assert/<key>/<session id>/<node>`` when it asserts (at most a few
times a lease). Writers are named ``(session id, node)`` on both.
"""

from __future__ import annotations

from collections.abc import Callable
from urllib.parse import quote, unquote

import zenoh

from nodes.core import graph
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


class PublisherLiveliness:
    """A subscription's side: ``on_writer(writer, present)`` for every publisher of ``key`` that appears or
    goes (those already there included), ``on_manual(writer)`` for each that asserts by hand and
    ``on_assert(writer)`` for each of its assertions. Callbacks run on Zenoh threads."""

    def __init__(self, session: zenoh.Session, key: str, on_writer: Callable[[Writer, bool], None],
                 on_manual: Callable[[Writer], None], on_assert: Callable[[Writer], None]) -> None:
        self._on_writer, self._on_manual, self._on_assert = on_writer, on_manual, on_assert
        enc = _chunk(key)
        self._publishers = graph.EndpointWatch(session, "pub", key, weak_callback(self._publisher))
        self._subs = [
            session.liveliness().declare_subscriber(f"{MANUAL}/{enc}/*/*", weak_callback(self._manual_sample),
                                                    history=True),
            session.declare_subscriber(f"{ASSERT}/{enc}/*/*", weak_callback(self._assert_sample)),
        ]

    def _publisher(self, entry: graph.GraphEntry, present: bool) -> None:
        self._on_writer((entry.session_id, entry.node), present)

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
