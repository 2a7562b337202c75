"""The fastest way in: a payload checked and decoded in one pass in C (msgspec), for messages that are valid.

Each message type gets a *shadow* ``msgspec.Struct`` whose field types carry the checks (integer ranges, finite
floats, array and string bounds, no unknown fields); ``msgspec.msgpack.Decoder`` then validates while it
decodes, with no intermediate dicts. A generated function turns the shadow tree into our message classes
(the types the rest of the code uses) and checks the equal-length rules.

It only *accepts*: anything msgspec refuses (or a rule breaks) raises, and ``msgs.codec.decode`` takes the
precise path, which names the field and the reason. So this path needs to accept a subset of what that path
accepts and build the same message, never to explain. Strings are not bounded here: the caller uses this path
only for payloads no longer than its string limit, so no string in them can exceed it.
"""

from __future__ import annotations

import functools
import sys
import threading
from collections.abc import Callable
from typing import Annotated, Any

import msgspec

from msgs.classes import maker
from msgs.compiled import compile_source, equal_length_lines, on_first_use
from msgs.idl import FLOAT_TYPES, INT_RANGES, STRING_TYPES, FieldSpec
from msgs.registry import default_value, get_class, get_spec

# What the decoder raises for data it does not accept (the caller falls back to the precise decoder): msgspec's
# own errors, and UnicodeDecodeError (a ValueError) for a string that is not UTF-8.
Refused = (msgspec.MsgspecError, ValueError)
_UNSET = msgspec.UNSET
_FINITE = msgspec.Meta(ge=-sys.float_info.max, le=sys.float_info.max)   # NaN fails both comparisons


class _Recursive(Exception):
    """A type that contains itself: no shadow struct (the precise path decodes it)."""


# One thread at a time inside msgspec. It completes a Struct's type information lazily, running Python code (so
# the GIL can pass to another thread) in the middle; a second thread decoding through the same shadow struct
# meanwhile read it half-built and crashed the process (segfault in mpack_decode: four trajectory controllers
# receiving their first JointTrajectory at once, ~1 launch in 6; tests/unit/test_msgs_structs_threads.py).
# Decoding holds the GIL throughout anyway, so the lock costs no parallelism, only ~0.1 µs.
_inside_msgspec = threading.Lock()


@functools.cache
def decoder(type_name: str, max_array_length: int, allow_nonfinite: bool) -> Callable[[bytes], Any] | None:
    """``decode(payload) -> message`` raising one of ``Refused``; None when the type has no fast path.
    Safe to call, and the decoder safe to use, from any number of threads."""
    with _inside_msgspec:
        try:
            shadow = _shadow(type_name, max_array_length, allow_nonfinite, ())
        except _Recursive:
            return None
        decode = msgspec.msgpack.Decoder(shadow).decode
    convert = _converter(type_name)

    def decode_message(payload: bytes) -> Any:
        with _inside_msgspec:
            shadow_message = decode(payload)
        return convert(shadow_message)

    return decode_message


_shadows: dict[tuple[str, int, bool], type] = {}   # nested types are shared by the structs that contain them


def _shadow(type_name: str, max_array_length: int, allow_nonfinite: bool, outer: tuple[str, ...]) -> type:
    key = (type_name, max_array_length, allow_nonfinite)
    known = _shadows.get(key)
    if known is not None:
        return known
    if type_name in outer:
        raise _Recursive(type_name)
    fields = []
    for i, f in enumerate(get_spec(type_name).fields):
        annotation = _field_type(f, max_array_length, allow_nonfinite, (*outer, type_name))
        # f0, f1 ... as attribute names (a ROS field name could clash with a Struct attribute), the ROS name on
        # the wire; absent fields stay UNSET and take their ROS default when converted
        fields.append((f"f{i}", annotation | msgspec.UnsetType, msgspec.field(default=_UNSET, name=f.name)))
    shadow = _shadows[key] = msgspec.defstruct(f"Shadow_{type_name.replace('/', '_')}", fields,
                                               forbid_unknown_fields=True, gc=False, module=__name__)
    return shadow


def _field_type(f: FieldSpec, max_array_length: int, allow_nonfinite: bool, outer: tuple[str, ...]) -> Any:
    if f.is_array:
        lengths = {"max_length": max_array_length if f.upper_bound is None else min(f.upper_bound, max_array_length)}
        if f.array_size is not None:
            lengths = {"min_length": f.array_size, "max_length": min(f.array_size, max_array_length)}
        if f.is_bytes:   # bin: one object, bounded by the message size (an image), not by the array limit
            if f.array_size is None and f.upper_bound is None:
                return bytes
            return Annotated[bytes, msgspec.Meta(**lengths)]
        return Annotated[list[_scalar_type(f, max_array_length, allow_nonfinite, outer)], msgspec.Meta(**lengths)]
    return _scalar_type(f, max_array_length, allow_nonfinite, outer)


def _scalar_type(f: FieldSpec, max_array_length: int, allow_nonfinite: bool, outer: tuple[str, ...]) -> Any:
    base = f.base
    if base in FLOAT_TYPES:   # msgspec takes an integer for a float too, as float(), like the precise path
        return float if allow_nonfinite else Annotated[float, _FINITE]
    if base in INT_RANGES:
        lo, hi = INT_RANGES[base]
        # msgspec bounds must fit an int64; msgpack itself holds no integer above uint64's maximum
        return Annotated[int, msgspec.Meta(ge=lo, le=hi) if hi < 2**63 else msgspec.Meta(ge=lo)]
    if base == "bool":
        return bool
    if base in STRING_TYPES:
        return str if f.string_bound is None else Annotated[str, msgspec.Meta(max_length=f.string_bound)]
    return _shadow(base, max_array_length, allow_nonfinite, outer)


class _Broken(msgspec.ValidationError):
    """An equal-length rule broken (the precise path says which field)."""


@functools.cache
def _converter(type_name: str) -> Callable[[Any], Any]:
    """Generated ``convert(shadow) -> message``: defaults for absent fields, nested types converted (single
    nested messages inline, so a Header costs no call)."""
    env: dict[str, Any] = {"_UNSET": _UNSET, "_Broken": _Broken}
    body = ["def convert(s):", *_convert_lines(type_name, "s", "result", env, "", 0), "    return result"]
    return compile_source("\n".join(body), env, "convert", f"struct converter of {type_name}")


def _convert_lines(type_name: str, source: str, result: str, env: dict[str, Any], prefix: str,
                   depth: int) -> list[str]:
    spec = get_spec(type_name)
    env[f"_cls{prefix}"] = maker(get_class(type_name))   # msgspec checked the values: stored as they are
    body = []
    args = []
    for i, f in enumerate(spec.fields):
        var = f"v{prefix}_{i}"
        env[f"_default{prefix}_{i}"] = functools.partial(default_value, f)
        body += [f"{var} = {source}.f{i}", f"if {var} is _UNSET:", f"    {var} = _default{prefix}_{i}()"]
        if not f.is_primitive:
            if f.is_array or depth >= 3:
                env[f"_conv{prefix}_{i}"] = on_first_use(functools.partial(_converter, f.base))
                call = f"[_conv{prefix}_{i}(x) for x in {var}]" if f.is_array else f"_conv{prefix}_{i}({var})"
                body += ["else:", f"    {var} = {call}"]
            else:
                body += ["else:", *("    " + line
                                    for line in _convert_lines(f.base, var, var, env, f"{prefix}_{i}", depth + 1))]
        args.append(var)
    body += equal_length_lines(type_name, prefix, "_Broken")
    body.append(f"{result} = _cls{prefix}({', '.join(args)})")
    return ["    " + line for line in body] if depth == 0 else body
