"""msgpack codec (DESIGN §5): one map per message, ROS field names, validated decoding.

Errors name the message type, the field path and the reason, e.g.
``sensor_msgs/msg/JointState: position[2]: not a finite number (nan)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgpack

from msgs.idl import FLOAT_TYPES, INT_RANGES, STRING_TYPES, FieldSpec
from msgs.registry import default_value, get_class, get_spec


class DecodeError(ValueError):
    """A payload that is not a valid message of the expected type."""

    def __init__(self, type_name: str, path: str, reason: str) -> None:
        self.type_name = type_name
        self.path = path
        self.reason = reason
        where = f"{type_name}: {path}: " if path else f"{type_name}: "
        super().__init__(where + reason)


@dataclass(frozen=True)
class Limits:
    """Size limits applied on decode (oversized messages are rejected, not truncated)."""

    max_message_bytes: int = 64 * 1024 * 1024
    max_array_length: int = 1_000_000
    max_string_length: int = 16 * 1024 * 1024
    allow_nonfinite: bool = False


DEFAULT_LIMITS = Limits()

# Cross-field rules ROS messages carry in their comments; checked after field decoding.
_EQUAL_LENGTH_RULES: dict[str, tuple[str, tuple[str, ...], bool]] = {
    # type: (reference field, fields that must match it, empty allowed)
    "sensor_msgs/msg/JointState": ("name", ("position", "velocity", "effort"), True),
    "zenroid_msgs/msg/HardwareState": ("name", ("position", "velocity", "effort"), False),
    "zenroid_msgs/msg/HardwareCommand": ("name", ("interface", "value"), False),
    "gazebo_msgs/msg/ModelStates": ("name", ("pose", "twist"), False),
    "humanoid_msgs/msg/HumanoidState": ("joint_names", ("joint_positions", "joint_velocities", "joint_efforts"), True),
}


# ---------------------------------------------------------------- encode

def to_dict(msg: Any) -> dict[str, Any]:
    """A message as plain msgpack-ready data (nested dicts, lists, bytes)."""
    return _encoder(msg._type)(msg)


def encode(msg: Any) -> bytes:
    return msgpack.packb(to_dict(msg), use_bin_type=True)


_encoders: dict[str, Callable[[Any], dict]] = {}


def _encoder(type_name: str) -> Callable[[Any], dict]:
    enc = _encoders.get(type_name)
    if enc is None:
        spec = get_spec(type_name)
        steps = [(f.name, _field_encoder(f)) for f in spec.fields]

        def enc(msg: Any, steps=steps) -> dict:
            return {name: conv(getattr(msg, name)) for name, conv in steps}

        _encoders[type_name] = enc
    return enc


def _field_encoder(f: FieldSpec) -> Callable[[Any], Any]:
    if f.is_bytes:
        return lambda v: bytes(v)
    if f.is_primitive:
        scalar = _scalar_encoder(f.base)
        if f.is_array:
            if f.base in FLOAT_TYPES:
                return lambda v: v.tolist() if hasattr(v, "tolist") else [float(x) for x in v]
            return lambda v: [scalar(x) for x in v]
        return scalar
    if f.is_array:
        return lambda v, t=f.base: [_encoder(t)(x) for x in v]
    return lambda v, t=f.base: _encoder(t)(v)


def _scalar_encoder(base: str) -> Callable[[Any], Any]:
    if base in FLOAT_TYPES:
        return float
    if base == "bool":
        return bool
    if base in INT_RANGES:
        return int
    return str


# ---------------------------------------------------------------- decode

def decode(cls: Any, data: bytes | bytearray | memoryview, limits: Limits = DEFAULT_LIMITS) -> Any:
    """Decode and validate ``data`` as a ``cls`` message; raises ``DecodeError``."""
    type_name = cls._type
    size = len(data)
    if size > limits.max_message_bytes:
        raise DecodeError(type_name, "", f"message is {size} bytes, over the {limits.max_message_bytes}-byte limit")
    try:
        obj = msgpack.unpackb(
            data, raw=False, strict_map_key=True,
            max_bin_len=limits.max_message_bytes, max_str_len=limits.max_string_length,
            max_array_len=limits.max_array_length, max_map_len=limits.max_array_length,
        )
    except (msgpack.ExtraData, msgpack.FormatError, msgpack.StackError, ValueError, TypeError) as exc:
        raise DecodeError(type_name, "", f"not a valid msgpack payload ({type(exc).__name__}: {exc})") from None
    return from_dict(cls, obj, limits)


def from_dict(cls: Any, obj: Any, limits: Limits = DEFAULT_LIMITS) -> Any:
    """Build a validated ``cls`` message from plain data (missing fields take ROS defaults)."""
    return _decode_message(cls._type, obj, "", limits, cls._type)


def _decode_message(type_name: str, obj: Any, path: str, limits: Limits, root: str) -> Any:
    if not isinstance(obj, dict):
        raise DecodeError(root, path, f"expected a map for {type_name}, got {_kind(obj)}")
    spec = get_spec(type_name)
    cls = get_class(type_name)
    known = spec.fields
    for key in obj:
        if not any(key == f.name for f in known):
            raise DecodeError(root, _join(path, str(key)), f"unknown field of {type_name}")
    values: dict[str, Any] = {}
    for f in known:
        fpath = _join(path, f.name)
        if f.name in obj:
            values[f.name] = _decode_field(f, obj[f.name], fpath, limits, root)
        else:
            values[f.name] = default_value(f)
    rule = _EQUAL_LENGTH_RULES.get(type_name)
    if rule:
        ref, others, empty_ok = rule
        n = len(values[ref])
        for other in others:
            m = len(values[other])
            if m != n and not (empty_ok and m == 0):
                raise DecodeError(root, _join(path, other),
                                  f"has {m} entries but {ref} has {n}" + (" (must be equal or empty)" if empty_ok else ""))
    return cls(**values)


def _decode_field(f: FieldSpec, value: Any, path: str, limits: Limits, root: str) -> Any:
    if f.is_array:
        if f.is_bytes:
            if isinstance(value, (bytes, bytearray)):
                items: Any = bytes(value)
            elif isinstance(value, list):
                items = bytes(_decode_int(f.base, x, f"{path}[{i}]", root) for i, x in enumerate(value))
            else:
                raise DecodeError(root, path, f"expected bytes or a list of ints, got {_kind(value)}")
        else:
            if not isinstance(value, list):
                raise DecodeError(root, path, f"expected a list, got {_kind(value)}")
            items = value
        n = len(items)
        if n > limits.max_array_length:
            raise DecodeError(root, path, f"{n} entries, over the limit of {limits.max_array_length}")
        if f.array_size is not None and n != f.array_size:
            raise DecodeError(root, path, f"expected exactly {f.array_size} entries, got {n}")
        if f.upper_bound is not None and n > f.upper_bound:
            raise DecodeError(root, path, f"at most {f.upper_bound} entries allowed, got {n}")
        if f.is_bytes:
            return items
        if f.base in FLOAT_TYPES:
            return _decode_float_list(items, path, limits, root)
        return [_decode_scalar(f, x, f"{path}[{i}]", limits, root) for i, x in enumerate(items)]
    return _decode_scalar(f, value, path, limits, root)


def _decode_float_list(items: list, path: str, limits: Limits, root: str) -> list[float]:
    # Fast path: all floats and a finite sum means every element is finite.
    if all(type(x) is float for x in items) and (limits.allow_nonfinite or math.isfinite(sum(items))):
        return items
    return [_decode_float(x, f"{path}[{i}]", limits, root) for i, x in enumerate(items)]


def _decode_scalar(f: FieldSpec, value: Any, path: str, limits: Limits, root: str) -> Any:
    base = f.base
    if base in FLOAT_TYPES:
        return _decode_float(value, path, limits, root)
    if base in INT_RANGES:
        return _decode_int(base, value, path, root)
    if base == "bool":
        if not isinstance(value, bool):
            raise DecodeError(root, path, f"expected a bool, got {_kind(value)}")
        return value
    if base in STRING_TYPES:
        if not isinstance(value, str):
            raise DecodeError(root, path, f"expected a string, got {_kind(value)}")
        bound = f.string_bound if f.string_bound is not None else limits.max_string_length
        if len(value) > bound:
            raise DecodeError(root, path, f"string of {len(value)} characters, over the limit of {bound}")
        return value
    return _decode_message(base, value, path, limits, root)


def _decode_float(value: Any, path: str, limits: Limits, root: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DecodeError(root, path, f"expected a number, got {_kind(value)}")
    value = float(value)
    if not limits.allow_nonfinite and not math.isfinite(value):
        raise DecodeError(root, path, f"not a finite number ({value})")
    return value


def _decode_int(base: str, value: Any, path: str, root: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise DecodeError(root, path, f"expected an integer ({base}), got {_kind(value)}")
    lo, hi = INT_RANGES[base]
    if not lo <= value <= hi:
        raise DecodeError(root, path, f"{value} is out of range for {base} [{lo}, {hi}]")
    return value


def _join(path: str, name: str) -> str:
    return f"{path}.{name}" if path else name


def _kind(value: Any) -> str:
    if value is None:
        return "nil"
    return {dict: "a map", list: "a list", str: "a string", bytes: "bytes", bool: "a bool",
            int: "an integer", float: "a float"}.get(type(value), type(value).__name__)
