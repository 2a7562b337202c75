"""The node graph as Zenoh liveliness tokens (what ``node list`` / ``topic list`` read).

Layout: ``@graph/<kind>/<session id>/<node>[/<name>/<type>]`` where ``<node>``, ``<name>`` and ``<type>``
are percent-encoded (``/`` → ``%2F``) so each is one key chunk. Kinds: node, pub, sub, srv, cli, act, actc.
"""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import quote, unquote

import zenoh

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
