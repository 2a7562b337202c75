"""Deterministic, non-default instances of any message type (for cross-process round trips), and URDFs."""

from __future__ import annotations

from typing import Any

from msgs.idl import FLOAT_TYPES, INT_RANGES
from msgs.registry import get_class, get_spec


def sample_message(type_name: str, depth: int = 0) -> Any:
    cls = get_class(type_name)
    values: dict[str, Any] = {}
    for i, f in enumerate(get_spec(type_name).fields):
        n = f.array_size if f.array_size is not None else (2 if depth < 3 else 0)
        if f.upper_bound is not None:
            n = min(n, f.upper_bound)
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


def chain_urdf(n: int, star: bool = False) -> str:
    """A robot of ``n`` revolute joints: a chain of ``n + 1`` links, or (``star``) every link on the first."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
                '</inertial>')
    links = "".join(f'<link name="l{i}">{inertial}</link>' for i in range(n + 1))
    joints = "".join(f'<joint name="j{i}" type="revolute"><parent link="l{0 if star else i}"/><child link="l{i + 1}"/>'
                     '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
                     for i in range(n))
    return f'<robot name="chain">{links}{joints}</robot>'


# A standard type zenroid does not define (bags hold topics of such types; readers skip them, said so).
UNDEFINED_TYPE = "statistics_msgs/msg/StatisticDataPoint"


def undefined_type_cdr() -> bytes:
    """A statistics_msgs/StatisticDataPoint, CDR as rosbags' Jazzy types write it."""
    from rosbags.typesys import Stores, get_typestore

    import msgs

    assert UNDEFINED_TYPE not in msgs.list_types(), f"zenroid now defines {UNDEFINED_TYPE}: pick another type"
    types = get_typestore(Stores.ROS2_JAZZY).types
    return bytes(get_typestore(Stores.ROS2_JAZZY).serialize_cdr(types[UNDEFINED_TYPE](data_type=1, data=21.5),
                                                               UNDEFINED_TYPE))
