"""ROS names: validated as rcl validates them, and resolved onto Zenoh key expressions (no leading slash).

Every name a request or a file carries (an entity, a namespace, a sensor, a plugin's node, a remapping, a
frame) goes through one of the ``*_problem`` checks before anything is declared on Zenoh: a ROS name has
letters, digits and ``_`` in ``/``-separated tokens that do not start with a digit, no empty token, no
wildcard, ``~`` only as a leading ``~/``, and a length within rmw's limits.
"""

from __future__ import annotations

import re

import zenoh

_VALID = re.compile(r"^[A-Za-z0-9_~/\-.@]+$")


# rmw's limits: a fully qualified topic name has 255 characters less 8 reserved for the middleware's prefixes
# and suffixes; a namespace 2 fewer than a topic name (room for '/x'); a node name 255.
MAX_TOPIC_LENGTH = 255 - 8
MAX_NAMESPACE_LENGTH = MAX_TOPIC_LENGTH - 2
MAX_NODE_NAME_LENGTH = 255
MAX_FRAME_LENGTH = 255
_TOKEN_CHARS = re.compile(r"[A-Za-z0-9_]")
# a TF frame id is no graph name (tf2 accepts '-' and '.' that URDF link names use), but never a wildcard
_FRAME = re.compile(r"^[A-Za-z0-9_.\-]+(/[A-Za-z0-9_.\-]+)*$")


class NameError_(ValueError):
    """An invalid topic/service/node name."""


def shown(value: str, width: int = 60) -> str:
    """``value`` quoted for an error message, cut to ``width`` characters with its length said."""
    if len(value) <= width:
        return repr(value)
    return f"{value[:width]!r}... ({len(value)} characters)"


def _length_problem(name: str, limit: int, what: str) -> str | None:
    if len(name) > limit:
        return f"{len(name)} characters, over the limit of {limit} for {what}"
    return None


def _tokens_problem(body: str) -> str | None:
    """Why the ``/``-separated tokens of ``body`` (no leading ``/`` or ``~/``) are not ROS tokens, or None."""
    for char in body:
        if char != "/" and not _TOKEN_CHARS.match(char):
            if char in "*$?#":
                return f"has {char!r}: wildcards and substitutions are not names"
            if char == "~":
                return "has '~' where only a leading '~/' is allowed"
            return f"has {char!r}: a ROS name has letters, digits, '_' and '/'"
    if body.endswith("/"):
        return "ends with '/'"
    for token in body.split("/"):
        if not token:
            return "has an empty token ('//')"
        if token[0].isdigit():
            return f"token {shown(token, 30)} starts with a digit"
    return None


def topic_problem(name: str, limit: int = MAX_TOPIC_LENGTH) -> str | None:
    """Why ``name`` is no valid ROS topic or service name (relative, ``/``absolute or ``~/``private), or None:
    rcl_validate_topic_name's rules, without substitutions, and rmw's length limit."""
    if not name:
        return "is empty"
    if (problem := _length_problem(name, limit, "a topic name")) is not None:
        return problem
    body = name[1:] if name.startswith("/") else name
    if name == "~":
        return None
    if body.startswith("~"):
        if not body.startswith("~/") or name.startswith("/"):
            return "has '~' where only a leading '~/' is allowed"
        body = body[2:]
    return _tokens_problem(body)


def namespace_problem(namespace: str) -> str | None:
    """Why ``namespace`` is no valid ROS namespace, or None. Empty (none) and ``/`` are valid; a leading and a
    trailing ``/`` are tolerated, as the command line and launch files write them."""
    if (problem := _length_problem(namespace, MAX_NAMESPACE_LENGTH, "a namespace")) is not None:
        return problem
    body = namespace.strip()
    body = body[1:] if body.startswith("/") else body
    body = body[:-1] if body.endswith("/") else body
    if not body:
        return None if not namespace.strip() or namespace.strip() == "/" else "has an empty token ('//')"
    if body.startswith("~"):
        return "has '~': a namespace cannot be private"
    return _tokens_problem(body)


def node_name_problem(name: str) -> str | None:
    """Why ``name`` is no valid node name (one token), or None; entity and sensor names follow it too."""
    if not name:
        return "is empty"
    if (problem := _length_problem(name, MAX_NODE_NAME_LENGTH, "a name")) is not None:
        return problem
    problem = _tokens_problem(name)
    if problem is None and "/" in name:
        return "has '/': it is one name, not a path"
    return problem


def frame_problem(frame: str) -> str | None:
    """Why ``frame`` cannot be a TF frame id, or None."""
    if not frame:
        return "is empty"
    if (problem := _length_problem(frame, MAX_FRAME_LENGTH, "a frame id")) is not None:
        return problem
    if not _FRAME.match(frame):
        bad = next((c for c in frame if not re.match(r"[A-Za-z0-9_.\-/]", c)), "/")
        if bad != "/":
            return f"has {bad!r}: a frame id has letters, digits, '_', '-', '.' and '/'"
        return "has an empty token ('//') or a leading or trailing '/'"
    return None


def check(problem: str | None, field: str, value: str) -> None:
    """Raise ``NameError_`` naming ``field``, the (shortened) value and the problem, if there is one."""
    if problem is not None:
        raise NameError_(f"{field} {shown(value)}: {problem}")


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
        raise NameError_(f"invalid name {shown(name)}: use letters, digits, '_', '-', '.', '/' and a leading '~/' "
                         "or '/'")
    if len(name) > MAX_TOPIC_LENGTH or len(namespace) > MAX_NAMESPACE_LENGTH:
        raise NameError_(f"invalid name {shown(name)} in namespace {shown(namespace)}: over rmw's limit of "
                         f"{MAX_TOPIC_LENGTH} characters for a topic name")
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
