"""The node graph as Zenoh liveliness tokens (what ``node list`` / ``topic list`` read).

Layout: ``@graph/<kind>/<session id>/<node>[/<name>/<type>]`` where ``<node>``, ``<name>`` and ``<type>``
are percent-encoded (``/`` → ``%2F``) so each is one key chunk. Kinds: node, pub, sub, srv, cli, act, actc.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from urllib.parse import quote, unquote

import msgpack
import zenoh

from nodes.core.weak_callback import weak_callback

ROOT = "@graph"
KINDS = ("node", "pub", "sub", "srv", "cli", "act", "actc")


def _enc(text: str) -> str:
    return quote(text, safe="") or "%00"


def _dec(chunk: str) -> str:
    return "" if chunk == "%00" else unquote(chunk)


def node_key(session_id: str, node: str) -> str:
    return f"{ROOT}/node/{session_id}/{_enc(node)}"


def endpoint_key(kind: str, session_id: str, node: str, name: str, type_name: str) -> str:
    if kind not in KINDS or kind == "node":
        raise ValueError(f"bad graph endpoint kind {kind!r}")
    return f"{ROOT}/{kind}/{session_id}/{_enc(node)}/{_enc(name)}/{_enc(type_name)}"


@dataclass(frozen=True)
class GraphEntry:
    kind: str
    session_id: str
    node: str
    name: str = ""
    type_name: str = ""


def parse_key(key: str) -> GraphEntry | None:
    """The entry a graph token stands for, None for a key that is not one (the only parser of this layout)."""
    parts = str(key).split("/")
    if len(parts) < 4 or parts[0] != ROOT or parts[1] not in KINDS:
        return None
    if parts[1] == "node" and len(parts) == 4:
        return GraphEntry("node", parts[2], _dec(parts[3]))
    if len(parts) == 6:
        return GraphEntry(parts[1], parts[2], _dec(parts[3]), _dec(parts[4]), _dec(parts[5]))
    return None


def snapshot(session: zenoh.Session, timeout: float = 1.0) -> list[GraphEntry]:
    """Every live graph entry (nodes and endpoints) visible from ``session``.

    A session opened a moment ago may not see all of the router's tokens yet (routes take a few ms to
    form), so the query is repeated until two answers in a row agree (or ``timeout`` passes).
    """
    import time

    deadline = time.monotonic() + timeout
    previous: set[GraphEntry] | None = None
    while True:
        entries: set[GraphEntry] = set()
        for reply in session.liveliness().get(f"{ROOT}/**", timeout=max(0.05, deadline - time.monotonic())):
            if reply.ok is not None:
                entry = parse_key(str(reply.ok.key_expr))
                if entry:
                    entries.add(entry)
        if (entries and entries == previous) or time.monotonic() >= deadline:
            return sorted(entries, key=lambda e: (e.kind, e.node, e.name))
        previous = entries
        time.sleep(0.03)


def node_names(session: zenoh.Session, timeout: float = 1.0) -> list[str]:
    return sorted({e.node for e in snapshot(session, timeout) if e.kind == "node"})


class NodeWatch:
    """Calls ``on_change(node, alive)`` for every node token that appears (``alive`` True) or goes away,
    tokens already live when the watch starts included (liveliness history). ``node`` is the name as the
    node announced it (``/ns/name``)."""

    def __init__(self, session: zenoh.Session, on_change: Callable[[str, bool], None]) -> None:
        self._on_change = on_change
        self._subscriber = session.liveliness().declare_subscriber(f"{ROOT}/node/**", self._on_sample, history=True)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        entry = parse_key(str(sample.key_expr))
        if entry is not None and entry.kind == "node":
            self._on_change(entry.node, sample.kind == zenoh.SampleKind.PUT)

    def close(self) -> None:
        try:
            self._subscriber.undeclare()
        except Exception:  # noqa: BLE001 - the session may already be closing; nothing to clean up then
            pass


class EndpointWatch:
    """Calls ``on_change(entry, present)`` for every ``kind`` endpoint (``pub``, ``sub`` ...) on ``key`` (already
    resolved) that appears or goes away, those already there included. Endpoints of one node on one key share
    a token: they count as one."""

    def __init__(self, session: zenoh.Session, kind: str, key: str,
                 on_change: Callable[[GraphEntry, bool], None]) -> None:
        if kind not in KINDS or kind == "node":
            raise ValueError(f"bad graph endpoint kind {kind!r}")
        self._on_change = on_change
        self._subscriber = session.liveliness().declare_subscriber(
            f"{ROOT}/{kind}/*/*/{_enc(key)}/*", weak_callback(self._on_sample), history=True)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        entry = parse_key(str(sample.key_expr))
        if entry is not None:
            self._on_change(entry, sample.kind == zenoh.SampleKind.PUT)

    def close(self) -> None:
        try:
            self._subscriber.undeclare()
        except Exception:  # noqa: BLE001 - the session may already be closing; nothing to clean up then
            pass


_PROBE_PAYLOAD = msgpack.packb({"names": []})


def from_node(reply: zenoh.Reply) -> bool:
    """Did a node's executor send ``reply``? A data reply, or an error reply in zenroid's layout (a msgpack
    map) are; a router's own ``Timeout`` error, sent when the node never answered, is not."""
    if reply.ok is not None:
        return True
    try:
        return isinstance(msgpack.unpackb(reply.err.payload.to_bytes(), raw=False), dict)
    except Exception:  # noqa: BLE001 - any other bytes: not a node's answer
        return False


ALIVE_SUFFIX = "_alive"   # <node>/_alive: answered on a Zenoh thread with how long the node's executor is stuck


def alive_key(node: str) -> str:
    return f"{node.strip('/')}/{ALIVE_SUFFIX}"


def probe_alive(session: zenoh.Session, node: str, on_answer: Callable[[float], None], timeout: float) -> None:
    """Ask ``node`` how long its executor has left queued work untaken (its spinner stuck): ``on_answer``
    gets that many seconds, on a Zenoh thread. A busy node that keeps taking work answers 0; a node whose
    session or callbacks are broken does not answer."""
    def on_reply(reply: zenoh.Reply) -> None:
        if reply.ok is None:
            return
        try:
            stalled = float(msgpack.unpackb(reply.ok.payload.to_bytes()).get("stalled_for", 0.0))
        except Exception:  # noqa: BLE001 - not a zenroid node's answer
            return
        on_answer(stalled)

    session.get(alive_key(node), on_reply, timeout=timeout)


def probe_node(session: zenoh.Session, node: str, on_answer: Callable[[], None], timeout: float) -> None:
    """Ask ``node`` (``ns/name``) whether it serves, without waiting: ``on_answer()`` runs on a Zenoh thread
    when any reply comes back, even an error one. Every node serves ``<node>/get_parameters`` from its
    executor, so an answer means its callbacks run, which a liveliness token alone does not say.
    Raises when the session is closed."""
    def on_reply(reply: zenoh.Reply) -> None:
        if from_node(reply):
            on_answer()

    session.get(f"{node}/get_parameters", on_reply, payload=_PROBE_PAYLOAD, timeout=timeout)
