"""Which nodes are up and which still serve: the launcher watches the graph's node liveliness tokens
(``wait_for``) and probes each watched node once a second (health): its ``<node>/get_parameters`` service,
and, from a zenroid node, ``<node>/_alive``, answered on a Zenoh thread with how long its executor has left
queued work untaken (so a node busy with a flood of requests is seen taking work, a stuck one is not).

A liveliness token only says the node's Zenoh session is open: Zenoh's own threads keep it alive even
when the node's Python loop is stuck, and a token can linger until the lease expires when the link is
cut. A service reply comes from the node's executor over the same links its data takes, so "answered
recently" means the node can still serve. The supervisor decides what to do with a silent node.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from nodes.core import graph

PROBE_PERIOD_S = 1.0
PROBE_TIMEOUT_S = 2.0


class NodeReadiness:
    """Keeps the set of live node names seen through the graph (history included) and probes the watched ones."""

    def __init__(self, session: Any) -> None:
        self._session = session
        self._lock = threading.Lock()
        self._alive: dict[str, int] = {}
        self._answered: dict[str, float | None] = {}  # watched node -> monotonic time of its last reply
        self._closed = threading.Event()
        self._watch = graph.NodeWatch(session, self._on_change)
        self._prober = threading.Thread(target=self._probe_loop, daemon=True, name="health-probe")
        self._prober.start()

    def _on_change(self, node: str, alive: bool) -> None:
        name = node.strip("/")
        with self._lock:
            if alive:
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

    # -- health ---------------------------------------------------------------------------------------
    def watch(self, full_name: str) -> None:
        """Probe ``full_name`` (``ns/name``) from now on; forgets replies from an earlier watch."""
        with self._lock:
            self._answered[full_name.strip("/")] = None

    def unwatch(self, full_name: str) -> None:
        with self._lock:
            self._answered.pop(full_name.strip("/"), None)

    def last_answer(self, full_name: str) -> float | None:
        """Monotonic time of the node's last reply to a probe since ``watch``, None if none yet."""
        with self._lock:
            return self._answered.get(full_name.strip("/"))

    def _probe_loop(self) -> None:
        while not self._closed.wait(PROBE_PERIOD_S):
            with self._lock:
                names = list(self._answered)
            for name in names:
                try:
                    graph.probe_node(self._session, name, self._replied(name), PROBE_TIMEOUT_S)
                    graph.probe_alive(self._session, name, self._on_alive(name), PROBE_TIMEOUT_S)
                except Exception:  # noqa: BLE001 - the session is closing: the loop ends with it
                    return

    def _replied(self, name: str):  # noqa: ANN202 - called on a Zenoh thread
        def on_answer() -> None:
            # Any reply, even an error one, comes from the node's executor: it is serving.
            with self._lock:
                if name in self._answered:
                    self._answered[name] = time.monotonic()
        return on_answer

    def _on_alive(self, name: str):  # noqa: ANN202 - called on a Zenoh thread
        def on_answer(stalled_for: float) -> None:
            # a zenroid node's own account: it last took work stalled_for s ago (a flood of requests that
            # delays its get_parameters answer is no silence)
            with self._lock:
                if name in self._answered:
                    seen = time.monotonic() - stalled_for
                    self._answered[name] = max(self._answered[name] or seen, seen)
        return on_answer

    def close(self) -> None:
        self._closed.set()
        self._watch.close()
