"""Who on the ROS 2 side publishes or subscribes what: the lazy switches of our mirrors.

One watcher per Zenoh session follows two sets of liveliness tokens: rmw_zenoh's ``@ros2_lv/<domain>/**``
(every ROS 2 publisher and subscription announces its data key there, and so do our own mirrors) and our
graph's ``@graph/node/**`` (which Zenoh sessions are zenroid processes). It tells a mirror whether a
publisher or a subscription token from a session that is *not* one of ours names its data key.

A subscription mirror listens on a data key only while a foreign publisher announces it. That keeps our own
subscribers off the data keys, so a topic mirror's Zenoh matching status counts foreign subscribers only
(ROS 2 subscriptions, recorders, bridges, ``z_sub``), except while a foreign publisher shares the topic.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable

import zenoh

from nodes.core.ros2 import names

_GRAPH_NODES = "@graph/node/**"
_WATCHED = (names.PUBLISHER, names.SUBSCRIPTION)

Watch = tuple[str, str]  # (endpoint kind, data key)


class RosGraph:
    def __init__(self, session: zenoh.Session, domain: int) -> None:
        self._lock = threading.Lock()
        self._zenroid_sessions: Counter[str] = Counter()
        self._endpoints: dict[str, names.Endpoint] = {}  # token key -> endpoint (MP and MS tokens)
        self._listeners: dict[Watch, list[Callable[[bool], None]]] = {}  # -> callbacks(present)
        self._present: set[Watch] = set()
        liveliness = session.liveliness()
        self._subs = [
            liveliness.declare_subscriber(_GRAPH_NODES, self._on_graph_node, history=True),
            liveliness.declare_subscriber(f"{names.ADMIN_SPACE}/{domain}/**", self._on_ros_token, history=True),
        ]

    # -- token streams (Zenoh threads)
    def _on_graph_node(self, sample: zenoh.Sample) -> None:
        parts = str(sample.key_expr).split("/")
        if len(parts) < 3:
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._zenroid_sessions[parts[2]] += 1
            else:
                self._zenroid_sessions[parts[2]] -= 1
                if self._zenroid_sessions[parts[2]] <= 0:
                    del self._zenroid_sessions[parts[2]]
        self._refresh()

    def _on_ros_token(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        endpoint = names.parse_endpoint_token(key)
        if endpoint is None or endpoint.kind not in _WATCHED:
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._endpoints[key] = endpoint
            else:
                self._endpoints.pop(key, None)
        self._refresh()

    def _refresh(self) -> None:
        with self._lock:
            present = {(e.kind, e.data_key) for e in self._endpoints.values() if e.zid not in self._zenroid_sessions}
            changed = (present ^ self._present) & set(self._listeners)
            self._present = present
            calls = [(cb, watch in present) for watch in changed for cb in self._listeners[watch]]
        for callback, is_present in calls:
            callback(is_present)

    # -- mirrors
    def watch(self, kind: str, data_key: str, callback: Callable[[bool], None]) -> None:
        """``callback(present)`` now and whenever the first foreign endpoint of ``kind`` (publisher or
        subscription) on ``data_key`` appears or the last one leaves."""
        with self._lock:
            self._listeners.setdefault((kind, data_key), []).append(callback)
            present = (kind, data_key) in self._present
        callback(present)

    def unwatch(self, kind: str, data_key: str, callback: Callable[[bool], None]) -> None:
        with self._lock:
            callbacks = self._listeners.get((kind, data_key), [])
            if callback in callbacks:
                callbacks.remove(callback)
            if not callbacks:
                self._listeners.pop((kind, data_key), None)

    def close(self) -> None:
        for sub in self._subs:
            try:
                sub.undeclare()
            except Exception:  # noqa: BLE001 - session already closing
                pass
