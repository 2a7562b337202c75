"""Property tests: encode → decode is the identity for every message type."""

from __future__ import annotations

from typing import Any

import msgpack
from hypothesis import given, settings
from hypothesis import strategies as st

import msgs
from msgs.idl import FLOAT_TYPES, INT_RANGES, STRING_TYPES, FieldSpec
from msgs.registry import get_class, get_spec


def _scalar(base: str) -> st.SearchStrategy:
    if base == "bool":
        return st.booleans()
    if base in INT_RANGES:
        lo, hi = INT_RANGES[base]
        return st.integers(lo, hi)
    if base == "float32":
        return st.floats(allow_nan=False, allow_infinity=False, width=32)
    if base in FLOAT_TYPES:
        return st.floats(allow_nan=False, allow_infinity=False)
    assert base in STRING_TYPES
    return st.text(max_size=12)


def _field(f: FieldSpec, depth: int) -> st.SearchStrategy:
    if f.is_bytes:
        n = f.array_size
        return st.binary(min_size=n or 0, max_size=n or 8)
    item = _scalar(f.base) if f.is_primitive else message_strategy(f.base, depth + 1)
    if f.is_array:
        if f.array_size is not None:
            return st.lists(item, min_size=f.array_size, max_size=f.array_size)
        return st.lists(item, max_size=f.upper_bound if f.upper_bound is not None else (3 if depth < 2 else 0))
    return item


def message_strategy(type_name: str, depth: int = 0) -> st.SearchStrategy:
    spec = get_spec(type_name)
    cls = get_class(type_name)
    # Types with equal-length rules get their arrays sized together.
    if type_name in ("sensor_msgs/msg/JointState", "humanoid_msgs/msg/HumanoidState",
                     "zenroid_msgs/msg/HardwareState", "zenroid_msgs/msg/HardwareCommand",
                     "gazebo_msgs/msg/ModelStates"):
        return st.integers(0, 4).flatmap(lambda n: _equal_length(spec, cls, n, depth))
    return st.fixed_dictionaries({f.name: _field(f, depth) for f in spec.fields}).map(lambda d: cls(**d))


def _equal_length(spec: Any, cls: Any, n: int, depth: int) -> st.SearchStrategy:
    parts = {}
    for f in spec.fields:
        if f.is_array and not f.is_bytes:
            item = _scalar(f.base) if f.is_primitive else message_strategy(f.base, depth + 1)
            parts[f.name] = st.lists(item, min_size=n, max_size=n)
        else:
            parts[f.name] = _field(f, depth)
    return st.fixed_dictionaries(parts).map(lambda d: cls(**d))


def _all_message_classes() -> list[str]:
    names = []
    for t in msgs.list_types():
        obj = msgs.get_type(t)
        if isinstance(obj, msgs.Service):
            names += [obj.Request._type, obj.Response._type]
        elif isinstance(obj, msgs.Action):
            names += [obj.Goal._type, obj.Result._type, obj.Feedback._type, obj.SendGoalRequest._type,
                      obj.GetResultResponse._type, obj.FeedbackMessage._type]
        else:
            names.append(obj._type)
    return names


ALL = _all_message_classes()


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(ALL).flatmap(message_strategy))
def test_round_trip_every_type(msg: Any) -> None:
    cls = type(msg)
    assert msgs.decode(cls, msgs.encode(msg)) == msg


@settings(max_examples=100, deadline=None)
@given(message_strategy("sensor_msgs/msg/JointState"))
def test_joint_state_is_a_plain_map_for_third_parties(msg: Any) -> None:
    plain = msgpack.unpackb(msgs.encode(msg), raw=False)
    assert isinstance(plain, dict)
    assert set(plain) == {"header", "name", "position", "velocity", "effort"}
    assert plain["name"] == msg.name and plain["position"] == msg.position
    assert plain["header"]["stamp"] == {"sec": msg.header.stamp.sec, "nanosec": msg.header.stamp.nanosec}
