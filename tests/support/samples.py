"""Deterministic, non-default instances of any message type (for cross-process round trips)."""

from __future__ import annotations

from typing import Any

from msgs.idl import FLOAT_TYPES, INT_RANGES
from msgs.registry import get_class, get_spec


def sample_message(type_name: str, depth: int = 0) -> Any:
    cls = get_class(type_name)
    values: dict[str, Any] = {}
    for i, f in enumerate(get_spec(type_name).fields):
        n = f.array_size if f.array_size is not None else (2 if depth < 3 else 0)
        if f.is_bytes:
            values[f.name] = bytes((i + k) % 256 for k in range(n))
        elif f.is_array:
            values[f.name] = [_scalar(f.base, i + k, depth) for k in range(n)]
        else:
            values[f.name] = _scalar(f.base, i, depth)
    return cls(**values)


def _scalar(base: str, i: int, depth: int) -> Any:
    if base == "bool":
        return i % 2 == 0
    if base in FLOAT_TYPES:
        return 0.5 + i * 0.25
    if base in INT_RANGES:
        return (i + 1) % 100
    if base in ("string", "wstring"):
        return f"value_{i}"
    return sample_message(base, depth + 1)
