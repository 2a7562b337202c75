"""Message classes the controllers use, looked up once from ``msgs`` (kept in one place)."""

from __future__ import annotations

import dataclasses
import functools
from typing import Any


@functools.cache
def msg_type(name: str) -> Any:
    import msgs

    return msgs.get_type(name)


@functools.cache
def _field_names(cls: Any) -> frozenset[str]:
    try:
        return frozenset(f.name for f in dataclasses.fields(cls))
    except TypeError:
        return frozenset()


def build(name: str, values: dict[str, Any]) -> Any:
    """A message of type ``name`` from a (possibly nested) dict; fields the type lacks are dropped so
    optional ROS-version differences (e.g. JTC state's ``reference`` vs ``desired``) do not matter."""
    import msgs

    cls = msg_type(name)
    known = _field_names(cls)
    if known:
        values = {k: v for k, v in values.items() if k in known}
    return msgs.from_dict(cls, values)


def sec_to_time(seconds: float) -> dict[str, int]:
    sec = int(seconds // 1)
    nanosec = int(round((seconds - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": sec, "nanosec": nanosec}
