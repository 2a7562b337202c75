"""builtin_interfaces Time/Duration <-> float seconds."""

from __future__ import annotations

import math
from typing import Any

from msgs.registry import get_class


def _split(seconds: float) -> tuple[int, int]:
    if not math.isfinite(seconds):
        raise ValueError(f"time must be finite, got {seconds}")
    sec = math.floor(seconds)
    nanosec = int(round((seconds - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return int(sec), nanosec


def time_map(seconds: float) -> dict[str, int]:
    """builtin_interfaces/Time of ``seconds`` as its msgpack map (hot paths: no message instance)."""
    sec, nanosec = _split(seconds)
    return {"sec": sec, "nanosec": nanosec}


def time_from_sec(seconds: float) -> Any:
    sec, nanosec = _split(seconds)
    return get_class("builtin_interfaces/msg/Time")(sec=sec, nanosec=nanosec)


def duration_from_sec(seconds: float) -> Any:
    sec, nanosec = _split(seconds)
    return get_class("builtin_interfaces/msg/Duration")(sec=sec, nanosec=nanosec)


def time_to_sec(t: Any) -> float:
    """Seconds of a Time or Duration (message or ``{sec, nanosec}`` map)."""
    if isinstance(t, dict):
        return t.get("sec", 0) + t.get("nanosec", 0) * 1e-9
    return t.sec + t.nanosec * 1e-9


duration_to_sec = time_to_sec
