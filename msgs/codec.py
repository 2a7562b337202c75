"""msgpack codec (docs/architecture.md, Messages on the wire): one map per message, ROS field names, validated decoding.

Errors name the message type, the field path and the reason, e.g.
``sensor_msgs/msg/JointState: position[2]: not a finite number (nan)``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgpack

from msgs import compiled, structs
from msgs.classes import maker
from msgs.idl import EQUAL_LENGTH_RULES, FLOAT_TYPES, INT_RANGES, STRING_TYPES, FieldSpec
from msgs.registry import default_value, get_class, get_spec


class FieldPathError(ValueError):
    """A message refused for one field: ``type: path: reason``, and the three parts as attributes."""

    after = ""  # what follows the reason in the text

    def __init__(self, type_name: str, path: str, reason: str) -> None:
        self.type_name = type_name
        self.path = path
        self.reason = reason
        where = f"{type_name}: {path}: " if path else f"{type_name}: "
        super().__init__(f"{where}{reason}{self.after}")


class DecodeError(FieldPathError):
    """A payload that is not a valid message of the expected type."""


class EncodeError(FieldPathError):
    """A message that cannot be sent: a value a receiver would refuse, named by its field path."""

    after = " (not sent)"


@dataclass(frozen=True)
class Limits:
    """Size limits applied on decode (oversized messages are rejected, not truncated)."""

    max_message_bytes: int = 64 * 1024 * 1024
    max_array_length: int = 1_000_000
    max_string_length: int = 16 * 1024 * 1024
    allow_nonfinite: bool = False


_FLOAT_ONLY = frozenset({float})   # a list of exactly these types needs no per-item check
_STR_ONLY = frozenset({str})
DEFAULT_LIMITS = Limits()


# ---------------------------------------------------------------- encode

def to_dict(msg: Any) -> dict[str, Any]:
    """A message as plain msgpack-ready data (nested dicts, lists, bytes)."""
    try:
        return compiled.encoder(msg._type)(msg)
    except Exception as exc:  # noqa: BLE001 - a value no setter saw (appended to a list, set inside one)
        raise _explain(msg, exc) from None


def encode(msg: Any) -> bytes:
    """msgpack bytes of ``msg``, checked as a receiver checks them: a value it would refuse (NaN, a string
    too long, a wrong type appended to a list) raises ``EncodeError`` naming the field, here, not there."""
    type_name = msg._type
    limits = _limits_for(type_name, DEFAULT_LIMITS)
    try:
        plain = compiled.checked_encoder(type_name, limits.allow_nonfinite)(msg)
    except Exception as exc:  # noqa: BLE001 - Refuse, or whatever a foreign object raised: say which field
        raise _explain(msg, exc) from None
    payload = compiled.packb(plain)
    if len(payload) > min(limits.max_string_length, limits.max_array_length):
        # only now can a string or an array be over the receiver's limits: the receiver's own check
        try:
            _precise(type(msg), plain, limits)
        except DecodeError as error:
            raise EncodeError(type_name, error.path, error.reason) from None
        if len(payload) > limits.max_message_bytes:
            raise EncodeError(type_name, "", f"message is {len(payload)} bytes, over the "
                                             f"{limits.max_message_bytes}-byte limit")
    return payload


def _explain(msg: Any, exc: Exception) -> EncodeError:
    """Why ``msg`` cannot be encoded, found by the precise decoder on a loose copy of it."""
    type_name = msg._type
    try:
        _precise(type(msg), _loose(msg, type_name), _limits_for(type_name, DEFAULT_LIMITS))
    except DecodeError as error:
        return EncodeError(type_name, error.path, error.reason)
    return EncodeError(type_name, "", f"cannot be encoded ({type(exc).__name__}: {exc})")


def _loose(value: Any, type_name: str) -> Any:
    """A message as plain data without converting anything, so the precise decoder sees the offending value
    (a message of another type stays an object: "expected a map for ..., got Point")."""
    if getattr(value, "_type", None) != type_name:
        return value
    out = {}
    for f in get_spec(type_name).fields:
        v = getattr(value, f.name, None)
        if f.is_array and not f.is_bytes and hasattr(v, "__iter__") and not isinstance(v, (str, bytes, dict)):
            v = v.tolist() if hasattr(v, "tolist") else list(v)
            if not f.is_primitive:
                v = [_loose(x, f.base) for x in v]
        elif not f.is_primitive and not f.is_array:
            v = _loose(v, f.base)
        out[f.name] = v
    return out


# ---------------------------------------------------------------- decode

_fast_default_decoders: dict[str, Callable[[Any], Any]] = {}  # the common case without hashing Limits


# Types whose float fields carry infinities as values: REP 117's LaserScan ranges (+inf: no return, -inf: too
# near; NaN: an erroneous reading). Everywhere else a non-finite number is refused.
NONFINITE_VALUES = frozenset({"sensor_msgs/msg/LaserScan"})


@functools.lru_cache(maxsize=16)
def _allowing_nonfinite(limits: Limits) -> Limits:
    return dataclasses.replace(limits, allow_nonfinite=True)


def _limits_for(type_name: str, limits: Limits) -> Limits:
    """``limits``, allowing non-finite numbers for the types that carry them as values (NONFINITE_VALUES)."""
    if type_name in NONFINITE_VALUES and not limits.allow_nonfinite:
        return _allowing_nonfinite(limits)
    return limits


def decode(cls: Any, data: bytes | bytearray | memoryview, limits: Limits = DEFAULT_LIMITS) -> Any:
    """Decode and validate ``data`` as a ``cls`` message; raises ``DecodeError``."""
    type_name = cls._type
    limits = _limits_for(type_name, limits)
    size = len(data)
    if size > limits.max_message_bytes:
        raise DecodeError(type_name, "", f"message is {size} bytes, over the {limits.max_message_bytes}-byte limit")
    if size <= limits.max_string_length:   # then no string in it can be over the limit (see msgs.structs)
        fast = structs.decoder(type_name, limits.max_array_length, limits.allow_nonfinite)   # cached per type
        if fast is not None:
            try:
                return fast(data)
            except structs.Refused:
                pass   # invalid, or valid in a way only the precise path handles: it decides and explains
    try:
        obj = msgpack.unpackb(
            data, raw=False, strict_map_key=True,
            max_bin_len=limits.max_message_bytes, max_str_len=limits.max_string_length,
            max_array_len=limits.max_array_length, max_map_len=limits.max_array_length,
        )
    except (msgpack.ExtraData, msgpack.FormatError, msgpack.StackError, ValueError, TypeError) as exc:
        if isinstance(exc, ValueError) and "exceeds max_" in str(exc):   # a size limit: say which field
            raise DecodeError(type_name, _oversized_field(data, limits), f"too long ({exc})") from None
        raise DecodeError(type_name, "", f"not a valid msgpack payload ({type(exc).__name__}: {exc})") from None
    fast = _fast_default_decoders.get(type_name) if limits is DEFAULT_LIMITS else None
    if fast is None:  # unpackb bounded every string and array with these limits
        fast = compiled.decoder(type_name, limits.max_array_length, limits.max_string_length,
                                limits.allow_nonfinite, True)
        if limits is DEFAULT_LIMITS:
            _fast_default_decoders[type_name] = fast
    try:
        return fast(obj)
    except compiled.Reject:
        return _precise(cls, obj, limits)


def _oversized_field(data: bytes | bytearray | memoryview, limits: Limits) -> str:
    """The top-level field whose value broke a size limit while unpacking ("" when it cannot be told): the map
    is unpacked again value by value under the same limits (``skip`` would not check them), stopping there."""
    unpacker = msgpack.Unpacker(raw=False, strict_map_key=False, max_buffer_size=max(1, len(data)),
                                max_bin_len=limits.max_message_bytes, max_str_len=limits.max_string_length,
                                max_array_len=limits.max_array_length, max_map_len=limits.max_array_length)
    unpacker.feed(data)
    try:
        for _ in range(unpacker.read_map_header()):
            key = unpacker.unpack()
            try:
                unpacker.unpack()
            except ValueError:
                return str(key)[:200]
    except Exception:  # noqa: BLE001 - not a map, or the key itself is the problem
        return ""
    return ""


def from_dict(cls: Any, obj: Any, limits: Limits = DEFAULT_LIMITS) -> Any:
    """Build a validated ``cls`` message from plain data (missing fields take ROS defaults).

    The generated decoder accepts valid data fast; whatever it declines goes through the precise
    decoder below, which accepts the same inputs and names the field and the reason when it rejects.
    The same values as ``decode`` are allowed (a LaserScan's infinities too: a bag's scans play back).
    """
    limits = _limits_for(cls._type, limits)
    try:
        return compiled.decoder(cls._type, limits.max_array_length, limits.max_string_length,
                                limits.allow_nonfinite)(obj)
    except compiled.Reject:
        return _precise(cls, obj, limits)


def _precise(cls: Any, obj: Any, limits: Limits) -> Any:
    """The explaining decoder: raises DecodeError naming the field path and the reason."""
    try:
        return _decoder(cls._type, limits)(obj)
    except _FieldError as exc:
        raise DecodeError(cls._type, ".".join(reversed(exc.path)).replace(".[", "["), exc.reason) from None


class _FieldError(Exception):
    """Raised inside compiled decoders; the path is collected (innermost first) on the way out."""

    def __init__(self, reason: str, path: list[str] | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.path = path or []


_decoders: dict[tuple[str, Limits], Callable[[Any], Any]] = {}
_MISSING = object()


_default_decoders: dict[str, Callable[[Any], Any]] = {}


def _decoder(type_name: str, limits: Limits) -> Callable[[Any], Any]:
    """A compiled validating decoder for ``type_name``: fast on valid data, precise on errors."""
    if limits is DEFAULT_LIMITS:  # the common case, without hashing the Limits dataclass
        dec = _default_decoders.get(type_name)
        if dec is None:
            dec = _default_decoders[type_name] = _compiled_decoder(type_name, limits)
        return dec
    return _compiled_decoder(type_name, limits)


def _compiled_decoder(type_name: str, limits: Limits) -> Callable[[Any], Any]:
    key = (type_name, limits)
    dec = _decoders.get(key)
    if dec is not None:
        return dec
    spec = get_spec(type_name)
    make = maker(get_class(type_name))
    # Placeholder first: recursive types resolve through the cache.
    _decoders[key] = lambda obj: _decoders[key](obj)
    steps = [(f.name, _field_decoder(f, limits), f) for f in spec.fields]
    names = frozenset(f.name for f in spec.fields)
    rule = EQUAL_LENGTH_RULES.get(type_name)

    def dec(obj: Any) -> Any:
        if type(obj) is not dict:
            raise _FieldError(f"expected a map for {type_name}, got {_kind(obj)}")
        for k in obj:
            if k not in names:
                raise _FieldError(f"unknown field of {type_name}", [str(k)])
        values = {}
        for name, fdec, f in steps:
            v = obj.get(name, _MISSING)
            if v is _MISSING:
                values[name] = default_value(f)
                continue
            try:
                values[name] = fdec(v)
            except _FieldError as exc:
                exc.path.append(name)
                raise
        if rule:
            ref, others, empty_ok = rule
            n = len(values[ref])
            for other in others:
                m = len(values[other])
                if m != n and not (empty_ok and m == 0):
                    raise _FieldError(f"has {m} entries but {ref} has {n}"
                                      + (" (must be equal or empty)" if empty_ok else ""), [other])
        return make(**values)

    _decoders[key] = dec
    return dec


def _field_decoder(f: FieldSpec, limits: Limits) -> Callable[[Any], Any]:
    if f.is_array:
        return _array_decoder(f, limits)
    return _scalar_decoder(f, limits)


def _scalar_decoder(f: FieldSpec, limits: Limits) -> Callable[[Any], Any]:
    base = f.base
    if base in FLOAT_TYPES:
        allow = limits.allow_nonfinite

        def dec_float(v: Any) -> float:
            if type(v) is float and (allow or math.isfinite(v)):
                return v
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise _FieldError(f"expected a number, got {_kind(v)}")
            v = float(v)
            if not allow and not math.isfinite(v):
                raise _FieldError(f"not a finite number ({v})")
            return v

        return dec_float
    if base in INT_RANGES:
        lo, hi = INT_RANGES[base]

        def dec_int(v: Any) -> int:
            if type(v) is not int:
                raise _FieldError(f"expected an integer ({base}), got {_kind(v)}")
            if not lo <= v <= hi:
                raise _FieldError(f"{v} is out of range for {base} [{lo}, {hi}]")
            return v

        return dec_int
    if base == "bool":
        def dec_bool(v: Any) -> bool:
            if type(v) is not bool:
                raise _FieldError(f"expected a bool, got {_kind(v)}")
            return v

        return dec_bool
    if base in STRING_TYPES:
        bound = f.string_bound if f.string_bound is not None else limits.max_string_length

        def dec_str(v: Any) -> str:
            if type(v) is not str:
                raise _FieldError(f"expected a string, got {_kind(v)}")
            if len(v) > bound:
                raise _FieldError(f"string of {len(v)} characters, over the limit of {bound}")
            return v

        return dec_str
    return compiled.on_first_use(functools.partial(_decoder, f.base, limits))


def _array_decoder(f: FieldSpec, limits: Limits) -> Callable[[Any], Any]:
    item = _scalar_decoder(f, limits)
    max_len = limits.max_array_length
    fixed, bound = f.array_size, f.upper_bound
    is_float = f.base in FLOAT_TYPES
    is_str = f.base in STRING_TYPES
    allow = limits.allow_nonfinite

    def check_len(n: int) -> None:
        if n > max_len:
            raise _FieldError(f"{n} entries, over the limit of {max_len}")
        if fixed is not None and n != fixed:
            raise _FieldError(f"expected exactly {fixed} entries, got {n}")
        if bound is not None and n > bound:
            raise _FieldError(f"at most {bound} entries allowed, got {n}")

    def items(v: list) -> list:
        out = []
        for i, x in enumerate(v):
            try:
                out.append(item(x))
            except _FieldError as exc:
                exc.path.append(f"[{i}]")
                raise
        return out

    if f.is_bytes:
        def dec_bytes(v: Any) -> bytes:
            if isinstance(v, (bytes, bytearray)):   # bin: bounded by the message size, not the array limit
                if fixed is not None and len(v) != fixed:
                    raise _FieldError(f"expected exactly {fixed} bytes, got {len(v)}")
                if bound is not None and len(v) > bound:
                    raise _FieldError(f"at most {bound} bytes allowed, got {len(v)}")
                return bytes(v)
            if isinstance(v, list):
                check_len(len(v))
                return bytes(items(v))
            raise _FieldError(f"expected bytes or a list of ints, got {_kind(v)}")

        return dec_bytes

    def dec_list(v: Any) -> list:
        if type(v) is not list:
            raise _FieldError(f"expected a list, got {_kind(v)}")
        check_len(len(v))
        # Fast paths: all floats with a finite sum (so every element is finite); all strings.
        if is_float and _FLOAT_ONLY.issuperset(map(type, v)) and (allow or math.isfinite(sum(v))):
            return v
        if is_str and _STR_ONLY.issuperset(map(type, v)) and sum(map(len, v)) <= limits.max_string_length:
            return v
        return items(v)

    return dec_list


def _kind(value: Any) -> str:
    if value is None:
        return "nil"
    return {dict: "a map", list: "a list", str: "a string", bytes: "bytes", bool: "a bool",
            int: "an integer", float: "a float"}.get(type(value), type(value).__name__)
