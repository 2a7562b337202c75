"""Property tests on every message type's decoder: encode → decode is the identity, and hostile input
(random bytes, random documents, wrong field values, unknown fields) raises DecodeError naming the field."""

from __future__ import annotations

import math
import re
from typing import Any

import msgpack
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import msgs
from msgs import structs
from msgs.codec import NONFINITE_VALUES
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


# --- every decoder, type by type ------------------------------------------------------------------------
# Round trips of random valid messages, and hostile input: random bytes, random msgpack documents, one field
# replaced by a value of the wrong kind, unknown fields. The decoder either returns a valid message or
# raises DecodeError naming the field; no other exception ever escapes.

JSON_LIKE = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats() | st.text(max_size=8)
    | st.binary(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4),
    max_leaves=12)


def _wrong_values(f: FieldSpec, nonfinite_ok: bool = False) -> list[Any]:
    """Values no decoder may accept for field ``f`` (the whole field replaced); ``nonfinite_ok``: the type
    carries infinities and NaN as values (msgs.codec.NONFINITE_VALUES: REP 117's LaserScan)."""
    nested = {"zz_unknown_field": 1}
    if f.is_bytes:
        wrong: list[Any] = [1.5, "text", {}, [300], [-1], ["x"]]
        if f.array_size is not None:
            wrong += [bytes(f.array_size - 1), bytes(f.array_size + 1)]
        return wrong
    if f.is_array:
        if f.is_primitive and f.base in STRING_TYPES:
            element: list[Any] = [[1], [1.5], [{}]]
        elif f.is_primitive and f.base == "bool":
            element = [["x"], [{}]]
        elif f.is_primitive:
            element = [["x"], [{}], [None]] + (
                [[math.nan], [math.inf]] if f.base in FLOAT_TYPES and not nonfinite_ok else [])
        else:
            element = [[1], ["x"], [nested]]
        wrong = [1.5, "text", {}, *element]
        if f.array_size is not None:
            wrong.append([] if f.array_size else [None])
        return wrong
    if not f.is_primitive:
        return [[], "text", 1.5, nested]
    if f.base == "bool":
        return ["x", 1.5, [], {}]
    if f.base in INT_RANGES:
        lo, hi = INT_RANGES[f.base]
        # out of range, where msgpack can still carry the number (int64 / uint64 are the whole of it)
        return ["x", 1.5, [], {}, math.nan, *(v for v in (lo - 1, hi + 1) if -(2**63) <= v < 2**64)]
    if f.base in FLOAT_TYPES:
        return ["x", [], {}] + ([] if nonfinite_ok else [math.nan, math.inf, -math.inf])
    wrong = [1, 1.5, [], {}]
    if f.string_bound is not None:
        wrong.append("x" * (f.string_bound + 1))
    return wrong


def _fields_of(type_name: str) -> list[FieldSpec]:
    return list(get_spec(type_name).fields)


def _decode_or_decode_error(cls: Any, payload: bytes) -> Any:
    try:
        msg = msgs.decode(cls, payload)
    except msgs.DecodeError as exc:
        return exc
    assert type(msg) is cls
    return msg


@pytest.mark.parametrize("type_name", ALL)
@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_each_type_round_trips(type_name: str, data: st.DataObject) -> None:
    msg = data.draw(message_strategy(type_name))
    assert msgs.decode(type(msg), msgs.encode(msg)) == msg


@pytest.mark.parametrize("type_name", ALL)
@settings(max_examples=10, deadline=None)
@given(raw=st.binary(max_size=64), doc=JSON_LIKE)
def test_each_type_decodes_random_input_or_raises_decode_error(type_name: str, raw: bytes, doc: Any) -> None:
    cls = get_class(type_name)
    _decode_or_decode_error(cls, raw)
    _decode_or_decode_error(cls, msgpack.packb(doc, use_bin_type=True))


@pytest.mark.parametrize("type_name", [t for t in ALL if _fields_of(t)])
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_each_type_names_the_field_with_a_wrong_value(type_name: str, data: st.DataObject) -> None:
    cls = get_class(type_name)
    plain = msgs.to_dict(data.draw(message_strategy(type_name)))
    f = data.draw(st.sampled_from(_fields_of(type_name)))
    plain[f.name] = data.draw(st.sampled_from(_wrong_values(f, type_name in NONFINITE_VALUES)))
    result = _decode_or_decode_error(cls, msgpack.packb(plain, use_bin_type=True))
    assert isinstance(result, msgs.DecodeError), f"{type_name}.{f.name} = {plain[f.name]!r} was accepted"
    assert re.match(rf"{re.escape(f.name)}($|[.\[])", result.path), (result.path, str(result))
    assert str(result).startswith(type_name)


@pytest.mark.parametrize("type_name", ALL)
def test_each_type_refuses_unknown_fields_and_non_maps(type_name: str) -> None:
    cls = get_class(type_name)
    error = _decode_or_decode_error(cls, msgpack.packb({"zz_unknown_field": 1}))
    assert isinstance(error, msgs.DecodeError) and error.path == "zz_unknown_field"
    for payload in (msgpack.packb([1, 2]), msgpack.packb(3), b"\xc1", b"\x92\x01"):
        assert isinstance(_decode_or_decode_error(cls, payload), msgs.DecodeError)


@pytest.mark.parametrize("type_name", ALL)
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_the_struct_fast_path_accepts_only_what_the_precise_path_accepts_and_builds_the_same(
        type_name: str, data: st.DataObject) -> None:
    """msgs.structs may refuse anything (the precise path then decides), but what it accepts must be exactly
    what the generated/precise decoders build from the same map: valid messages, integers where floats go,
    and each field replaced by a value no decoder may accept."""
    cls = get_class(type_name)
    plain = msgs.to_dict(data.draw(message_strategy(type_name)))
    fields = _fields_of(type_name)
    if fields and data.draw(st.booleans()):
        f = data.draw(st.sampled_from(fields))
        if f.is_array and f.is_primitive and f.base in FLOAT_TYPES and plain[f.name]:
            plain[f.name] = [int(x) if math.isfinite(x) and abs(x) < 2**53 else x for x in plain[f.name]]
        else:
            plain[f.name] = data.draw(st.sampled_from(_wrong_values(f, type_name in NONFINITE_VALUES)))
    payload = msgpack.packb(plain, use_bin_type=True)
    fast = structs.decoder(type_name, 1000, False)
    assert fast is not None
    try:
        got = fast(payload)
    except structs.Refused:
        return
    expected = msgs.from_dict(cls, msgpack.unpackb(payload, raw=False))   # raises if it would refuse
    assert type(got) is cls and got == expected
