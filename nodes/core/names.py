"""ROS-style name resolution onto Zenoh key expressions (no leading slash)."""

from __future__ import annotations

import re

import zenoh

_VALID = re.compile(r"^[A-Za-z0-9_~/\-.@]+$")


class NameError_(ValueError):
    """An invalid topic/service/node name."""


def _clean(ns: str) -> str:
    return "/".join(p for p in ns.split("/") if p)


def resolve(name: str, namespace: str = "", node_name: str = "", *, wildcards: bool = False) -> str:
    """``x`` → ``ns/x``; ``/x`` → ``x``; ``~/x`` → ``ns/node/x``.

    With ``wildcards`` (subscriptions), whole chunks ``*`` and ``**`` are allowed (Zenoh key wildcards).
    """
    checked = name
    if wildcards:
        checked = "/".join("w" if chunk in ("*", "**") else chunk for chunk in name.split("/"))
    if not name or not _VALID.match(checked) or "//" in name.strip("/"):
        raise NameError_(f"invalid name {name!r}: use letters, digits, '_', '-', '.', '/' and a leading '~/' or '/'")
    ns = _clean(namespace)
    if name.startswith("~"):
        rest = name[1:].lstrip("/")
        base = "/".join(p for p in (ns, node_name) if p)
        return f"{base}/{rest}" if rest else base
    if name.startswith("/"):
        return _clean(name)
    return "/".join(p for p in (ns, _clean(name)) if p)


def apply_remap(resolved: str, remap: dict[str, str], namespace: str = "", node_name: str = "") -> str:
    """Apply remap rules; rule keys and values are resolved like names before matching."""
    for src, dst in remap.items():
        try:
            if resolve(src, namespace, node_name) == resolved or src == resolved:
                return resolve(dst, namespace, node_name)
        except NameError_:
            continue
    return resolved


def parse_assignment(text: str) -> tuple[str, str]:
    """``name:=value`` → (name, value)."""
    if ":=" not in text:
        raise ValueError(f"expected NAME:=VALUE, got {text!r}")
    name, value = text.split(":=", 1)
    if not name.strip():
        raise ValueError(f"empty name in {text!r}")
    return name.strip(), value


def check_key(key: str) -> None:
    """Raise ValueError naming what is wrong when ``key`` is not a valid Zenoh key expression."""
    try:
        zenoh.KeyExpr(key)
    except Exception as exc:  # noqa: BLE001 - zenoh raises a plain ZError that names the fault
        raise ValueError(str(exc).split(" at ")[0]) from None


def keys_intersect(pattern: str, key: str) -> bool:
    """Does some key match both ``pattern`` (which may hold wildcards) and ``key``? False when either is invalid."""
    try:
        return zenoh.KeyExpr(pattern).intersects(zenoh.KeyExpr(key))
    except Exception:  # noqa: BLE001 - a name that is no valid key matches nothing
        return False
