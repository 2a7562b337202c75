"""Who on the ROS 2 side subscribes to what: the lazy switch of our topic mirrors.

One watcher per Zenoh session follows two sets of liveliness tokens: rmw_zenoh's ``@ros2_lv/<domain>/**``
(every ROS 2 subscription announces its data key there, and so do our own mirrors) and our graph's
``@graph/node/**`` (which Zenoh sessions are zenroid processes). A topic mirror encodes CDR only while a
subscription token from a session that is *not* one of ours matches its data key.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable

import zenoh

from nodes.core.ros2 import names

_GRAPH_NODES = "@graph/node/**"


class RosGraph:
    def __init__(self, session: zenoh.Session, domain: int) -> None:
        self._lock = threading.Lock()
        self._zenroid_sessions: Counter[str] = Counter()
        self._subscriptions: dict[str, names.Endpoint] = {}  # token key -> endpoint (MS tokens only)
        self._listeners: dict[str, list[Callable[[bool], None]]] = {}  # data key -> callbacks(active)
        self._active: set[str] = set()
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
        if endpoint is None or endpoint.kind != names.SUBSCRIPTION:
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._subscriptions[key] = endpoint
            else:
                self._subscriptions.pop(key, None)
        self._refresh()

    def _refresh(self) -> None:
        with self._lock:
            wanted = {e.data_key for e in self._subscriptions.values() if e.zid not in self._zenroid_sessions}
            changed = (wanted ^ self._active) & set(self._listeners)
            self._active = wanted
            calls = [(cb, key in wanted) for key in changed for cb in self._listeners[key]]
        for callback, active in calls:
            callback(active)

    # -- mirrors
    def watch(self, data_key: str, callback: Callable[[bool], None]) -> None:
        """``callback(active)`` now and whenever a foreign subscriber to ``data_key`` appears or leaves."""
        with self._lock:
            self._listeners.setdefault(data_key, []).append(callback)
            active = data_key in self._active
        callback(active)

    def unwatch(self, data_key: str, callback: Callable[[bool], None]) -> None:
        with self._lock:
            callbacks = self._listeners.get(data_key, [])
            if callback in callbacks:
                callbacks.remove(callback)
            if not callbacks:
                self._listeners.pop(data_key, None)

    def close(self) -> None:
        for sub in self._subs:
            try:
                sub.undeclare()
            except Exception:  # noqa: BLE001 - session already closing
                pass
