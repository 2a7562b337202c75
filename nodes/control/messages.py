"""Message classes the controllers use, looked up once from ``msgs`` (kept in one place)."""

from __future__ import annotations

import functools
from typing import Any


@functools.cache
def msg_type(name: str) -> Any:
    import msgs

    return msgs.get_type(name)


def sec_to_time(seconds: float) -> dict[str, int]:
    sec = int(seconds // 1)
    nanosec = int(round((seconds - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": sec, "nanosec": nanosec}
