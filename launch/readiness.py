"""Which nodes are up: the launcher watches the graph's node liveliness tokens (``wait_for``)."""

from __future__ import annotations

import threading
from urllib.parse import unquote

import zenoh

NODE_TOKENS = "@graph/node/**"


def node_name_of(key: str) -> str | None:
    """The node name in a graph node token ``@graph/node/<session id>/<percent-encoded name>``."""
    try:
        from nodes.core.graph import parse_key
    except ImportError:  # the graph layout is owned by nodes.core; this fallback mirrors it
        parts = str(key).split("/")
        if len(parts) == 4 and parts[:2] == ["@graph", "node"]:
            return unquote(parts[3])
        return None
    entry = parse_key(str(key))
    return entry.node if entry is not None and entry.kind == "node" else None


class NodeReadiness:
    """Keeps the set of live node names seen through liveliness (history included)."""

    def __init__(self, session: zenoh.Session) -> None:
        self._lock = threading.Lock()
        self._alive: dict[str, int] = {}
        self._subscriber = session.liveliness().declare_subscriber(NODE_TOKENS, self._on_sample, history=True)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        name = node_name_of(str(sample.key_expr))
        if name is None:
            return
        name = name.strip("/")
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._alive[name] = self._alive.get(name, 0) + 1
            else:
                count = self._alive.get(name, 0) - 1
                if count > 0:
                    self._alive[name] = count
                else:
                    self._alive.pop(name, None)

    def is_alive(self, full_name: str) -> bool:
        """True when a node named ``ns/name`` (or plain ``name`` when it has no namespace) is live."""
        with self._lock:
            return full_name.strip("/") in self._alive

    def alive(self) -> list[str]:
        with self._lock:
            return sorted(self._alive)

    def close(self) -> None:
        try:
            self._subscriber.undeclare()
        except Exception:  # the session may already be closing; nothing to clean up then
            pass
