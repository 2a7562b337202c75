"""Encoders, decoders and builders generated from the ``.msg`` definitions, compiled once per type.

Each function is Python source written from the type's field list and compiled with ``exec`` (no user
input reaches the source: names come from parsed definitions, which only admit identifiers), so a
message is encoded or checked by straight-line code with no per-field closures or loops over specs:

- ``encoder(type)(msg)``: a message instance -> its msgpack map (what ``msgs.encode`` packs);
- ``decoder(type, limits)(obj)``: an unpacked map -> a validated instance. It only *accepts*; on any
  doubt it raises ``Reject`` and the caller falls back to the precise decoder in ``msgs.codec``, which
  names the field and the reason. So both decoders accept exactly the same inputs.
- ``builder(type)(**fields)``: keyword fields (schema names, checked by Python's signature) -> the
  complete map with ROS defaults filled in: the hot paths (hardware frames, joint_states, tf, clock)
  build their messages with these instead of hand-spelled dicts;
- ``packer(type)(**fields)``: the same, packed to msgpack bytes.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import msgpack

from msgs.classes import maker
from msgs.idl import EQUAL_LENGTH_RULES, FLOAT_TYPES, INT_RANGES, STRING_TYPES, FieldSpec, MsgSpec
from msgs.registry import default_value, get_class, get_spec

# msgpack's Packer starts with a 256 KiB buffer, which glibc serves with mmap and releases with munmap for
# every message packed on a Zenoh callback thread (seen with strace in the controller manager and the
# simulator: one mmap/munmap pair, page faults and a TLB shootdown per control period). Messages are a
# few KiB; the buffer still grows when one is larger.
_PACK_BUFFER_BYTES = 16 * 1024


def packb(obj: Any) -> bytes:
    """msgpack bytes of plain data (str as str, bytes as bin), with a heap-sized first buffer."""
    return msgpack.packb(obj, buf_size=_PACK_BUFFER_BYTES)


_FLOAT_ONLY = frozenset({float})
_STR_ONLY = frozenset({str})
_INF = math.inf


class Reject(Exception):
    """The fast decoder declines an input; the precise decoder decides (and explains)."""


def _ident(type_name: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in type_name)


# ---------------------------------------------------------------- encoders (instance -> map)

def _floats(v: Any) -> list[float]:
    if type(v) is list and _FLOAT_ONLY.issuperset(map(type, v)):
        return v
    if hasattr(v, "tolist"):  # numpy arrays
        v = v.tolist()
    return [float(x) for x in v]


def _strs(v: Any) -> list[str]:
    return v if type(v) is list and _STR_ONLY.issuperset(map(type, v)) else [str(x) for x in v]


def _scalar_conv(base: str) -> str:
    if base in FLOAT_TYPES:
        return "float"
    if base == "bool":
        return "bool"
    if base in INT_RANGES:
        return "int"
    return "str"


@functools.cache
def encoder(type_name: str) -> Callable[[Any], dict]:
    spec = get_spec(type_name)
    env: dict[str, Any] = {"_floats": _floats, "_strs": _strs, "bytes": bytes}
    lines = ["def encode(m):", f"    return {_encode_expr(spec, 'm', env, depth=0)}"]
    return compile_source("\n".join(lines), env, "encode", f"encoder of {type_name}")


def _encode_expr(spec: MsgSpec, var: str, env: dict[str, Any], depth: int) -> str:
    """A dict display for the message in ``var``; nested single messages are inlined (up to a depth)."""
    items = []
    for f in spec.fields:
        value = f"{var}.{f.name}"
        if f.is_bytes:
            expr = f"bytes({value})"
        elif f.is_primitive:
            if f.is_array:
                expr = (f"_floats({value})" if f.base in FLOAT_TYPES else f"_strs({value})" if f.base in STRING_TYPES
                        else f"[{_scalar_conv(f.base)}(x) for x in {value}]")
            else:
                conv = _scalar_conv(f.base)
                expr = f"({value} if type({value}) is {conv} else {conv}({value}))"
        elif f.is_array:
            name = f"_enc_{_ident(f.base)}"
            env[name] = encoder(f.base)
            expr = f"[{name}(x) for x in {value}]"
        elif depth < 3:
            expr = _encode_expr(get_spec(f.base), value, env, depth + 1)
        else:
            name = f"_enc_{_ident(f.base)}"
            env[name] = encoder(f.base)
            expr = f"{name}({value})"
        items.append(f"{f.name!r}: {expr}")
    return "{" + ", ".join(items) + "}"


# ---------------------------------------------------------------- checked encoders (what msgs.encode sends)

class Refuse(Exception):
    """A value the checked encoder will not send; ``msgs.codec`` then finds and names the field."""


def _c_float(v: Any, finite: bool) -> float:
    if type(v) is bool or not isinstance(v, (int, float)) and not hasattr(v, "__float__"):
        raise Refuse
    v = float(v)
    if finite and not -_INF < v < _INF:
        raise Refuse
    return v


def _c_int(v: Any, lo: int, hi: int) -> int:
    if type(v) is int and lo <= v <= hi:
        return v
    if isinstance(v, float) or not hasattr(v, "__index__"):
        raise Refuse
    v = v.__index__()
    if not lo <= v <= hi:
        raise Refuse
    return v


def _c_bool(v: Any) -> bool:
    if type(v) is bool or type(v).__name__ == "bool_":
        return bool(v)
    raise Refuse


def _c_items(v: Any, size: int | None, bound: int | None) -> list:
    """``v`` as a list of at most ``bound`` (exactly ``size``) items: lists as they are, numpy arrays, tuples..."""
    if type(v) is not list:
        if isinstance(v, (str, bytes, bytearray, dict)) or not hasattr(v, "__iter__"):
            raise Refuse
        v = v.tolist() if hasattr(v, "tolist") else list(v)
    if bound is not None and len(v) > bound or size is not None and len(v) != size:
        raise Refuse
    return v


def _c_floats(v: Any, size: int | None, bound: int | None, finite: bool) -> list[float]:
    return [_c_float(x, finite) for x in _c_items(v, size, bound)]


def _c_strs(v: Any, size: int | None, bound: int | None, string_bound: int | None) -> list[str]:
    return [_c_str(x, string_bound) for x in _c_items(v, size, bound)]


def _c_bytes(v: Any, size: int | None, bound: int | None) -> bytes:
    if type(v) is not bytes:
        if isinstance(v, str):
            raise Refuse
        try:
            v = bytes(v)
        except (TypeError, ValueError):
            raise Refuse from None
    if bound is not None and len(v) > bound or size is not None and len(v) != size:
        raise Refuse
    return v


def _c_str(v: Any, bound: int | None) -> str:
    if not isinstance(v, str) or bound is not None and len(v) > bound:
        raise Refuse
    return str(v)


def _refuse() -> Any:
    raise Refuse


@functools.cache
def checked_encoder(type_name: str, allow_nonfinite: bool) -> Callable[[Any], dict]:
    """``encode(msg)`` -> the map, refusing (``Refuse``) what a receiver would refuse: wrong types (a value
    appended to a list, a message of another type), NaN and infinities (unless ``allow_nonfinite``), integers
    out of range, bounded strings and sequences too long, the equal-length rules. The limits on unbounded
    strings and arrays are the caller's to check, on the packed size (no string or array can be longer than
    the payload). Values of the right type pass as they are, inline, so it costs about what ``encoder`` does."""
    spec = get_spec(type_name)
    env: dict[str, Any] = {
        "_c_float": _c_float, "_c_int": _c_int, "_c_bool": _c_bool, "_c_str": _c_str, "_c_items": _c_items,
        "_c_floats": _c_floats, "_c_strs": _c_strs, "_c_bytes": _c_bytes, "_refuse": _refuse, "Refuse": Refuse,
        "_INF": _INF, "_t": type, "_isfinite": math.isfinite, "_FO": _FLOAT_ONLY, "_SO": _STR_ONLY,
        "_IO": frozenset({int}), "_BO": frozenset({bool}),
    }
    names: dict[str, str] = {}   # top-level field -> the local holding its value (for the equal-length rule)
    body = [f"    d = {_checked_expr(spec, 'm', env, 0, allow_nonfinite, names)}"]
    rule = EQUAL_LENGTH_RULES.get(type_name)
    if rule:
        ref, others, empty_ok = rule
        for other in others:
            m, n = f"len({names[other]})", f"len({names[ref]})"
            body += [f"    if {m} != {n}" + (f" and {m} != 0:" if empty_ok else ":"), "        raise Refuse"]
    source = "\n".join(["def encode(m):", *body, "    return d"])
    return compile_source(source, env, "encode", f"checked encoder of {type_name}")


def _checked_expr(spec: MsgSpec, var: str, env: dict[str, Any], depth: int, allow_nonfinite: bool,
                  names: dict[str, str], prefix: str = "") -> str:
    """A dict display of the message in ``var``, each value read once into a local (``v<prefix>_<i>``) and
    passed on as it is when it has the right type, else through a converting check that may refuse."""
    items = []
    for i, f in enumerate(spec.fields):
        v = f"v{prefix}_{i}"
        if depth == 0:
            names[f.name] = v
        read = f"({v} := {var}.{f.name})"
        size, bound, sbound = f.array_size, f.upper_bound, f.string_bound
        lengths = (f" and len({v}) == {size}" if size is not None else "") + (
            f" and len({v}) <= {bound}" if bound is not None else "")
        if f.is_bytes:
            expr = f"({v} if _t{read} is bytes{lengths} else _c_bytes({v}, {size}, {bound}))"
        elif f.is_array and f.is_primitive:
            if f.base in FLOAT_TYPES:
                finite = "" if allow_nonfinite else f" and _isfinite(sum({v}))"
                fast = f"_FO.issuperset(map(_t, {v})){finite}"
                slow = f"_c_floats({v}, {size}, {bound}, {not allow_nonfinite})"
            elif f.base in STRING_TYPES:
                fast = f"_SO.issuperset(map(_t, {v}))" + (
                    f" and (not {v} or max(map(len, {v})) <= {sbound})" if sbound is not None else "")
                slow = f"_c_strs({v}, {size}, {bound}, {sbound})"
            elif f.base in INT_RANGES:
                lo, hi = INT_RANGES[f.base]
                fast = f"_IO.issuperset(map(_t, {v})) and (not {v} or {lo} <= min({v}) and max({v}) <= {hi})"
                slow = f"[_c_int(x, {lo}, {hi}) for x in _c_items({v}, {size}, {bound})]"
            else:
                fast = f"_BO.issuperset(map(_t, {v}))"
                slow = f"[_c_bool(x) for x in _c_items({v}, {size}, {bound})]"
            expr = f"({v} if _t{read} is list and {fast}{lengths} else {slow})"
        elif f.is_array:
            name, cls = f"_enc_{_ident(f.base)}", f"_cls_{_ident(f.base)}"
            env[name] = checked_encoder(f.base, allow_nonfinite)
            env[cls] = get_class(f.base)
            expr = f"[({name}(x) if _t(x) is {cls} else _refuse()) for x in _c_items({var}.{f.name}, {size}, {bound})]"
            if depth == 0:
                expr = f"({v} := {expr})"
        elif f.base in FLOAT_TYPES:
            expr = (f"({v} if _t{read} is float else _c_float({v}, False))" if allow_nonfinite
                    else f"({v} if _t{read} is float and -_INF < {v} < _INF else _c_float({v}, True))")
        elif f.base in INT_RANGES:
            lo, hi = INT_RANGES[f.base]
            expr = f"({v} if _t{read} is int and {lo} <= {v} <= {hi} else _c_int({v}, {lo}, {hi}))"
        elif f.base == "bool":
            expr = f"({v} if _t{read} is bool else _c_bool({v}))"
        elif f.base in STRING_TYPES:
            check = f" and len({v}) <= {sbound}" if sbound is not None else ""
            expr = f"({v} if _t{read} is str{check} else _c_str({v}, {sbound}))"
        elif depth < 3 and f.base not in EQUAL_LENGTH_RULES:
            cls = f"_cls_{_ident(f.base)}"
            env[cls] = get_class(f.base)
            inner = _checked_expr(get_spec(f.base), v, env, depth + 1, allow_nonfinite, names, f"{prefix}_{i}")
            expr = f"({inner} if _t{read} is {cls} else _refuse())"
        else:
            name, cls = f"_enc_{_ident(f.base)}", f"_cls_{_ident(f.base)}"
            env[name] = checked_encoder(f.base, allow_nonfinite)
            env[cls] = get_class(f.base)
            expr = f"({name}({v}) if _t{read} is {cls} else _refuse())"
        items.append(f"{f.name!r}: {expr}")
    return "{" + ", ".join(items) + "}"


# ---------------------------------------------------------------- fast decoders (map -> instance)

@functools.cache
def decoder(type_name: str, max_array_length: int, max_string_length: int, allow_nonfinite: bool,
            lengths_checked: bool = False) -> Callable[[Any], Any]:
    """Fast validating decoder for one set of limits; raises ``Reject`` instead of explaining.

    ``lengths_checked``: the map comes from ``msgpack.unpackb`` with these limits as its ``max_str_len``
    and ``max_array_len``, so unbounded strings need no length check of their own.
    """
    env: dict[str, Any] = {
        "Reject": Reject, "_FLOAT_ONLY": _FLOAT_ONLY, "_STR_ONLY": _STR_ONLY, "_INF": _INF,
        "_isfinite": math.isfinite, "_MAXLEN": max_array_length, "_MAXSTR": max_string_length,
        "_ALLOW_NONFINITE": allow_nonfinite, "_LENGTHS_CHECKED": lengths_checked, "_join": "".join,
    }
    body = ["def decode(o):", *_decode_lines(type_name, "o", "result", env, "", 0, allow_nonfinite,
                                              lengths_checked), "    return result"]
    return compile_source("\n".join(body), env, "decode", f"decoder of {type_name}")


def _decode_lines(type_name: str, obj: str, result: str, env: dict[str, Any], prefix: str, depth: int,
                  allow_nonfinite: bool, lengths_checked: bool) -> list[str]:
    """Lines (indented for the function body) that check the map in ``obj`` and bind ``result`` to the
    instance; nested single messages are inlined up to a depth (no call per Header or Time)."""

    spec = get_spec(type_name)
    env[f"_cls{prefix}"] = maker(get_class(type_name))   # values already checked: stored without a second check
    env[f"_names{prefix}"] = frozenset(f.name for f in spec.fields)
    body = [f"    if type({obj}) is not dict or not _names{prefix}.issuperset({obj}):", "        raise Reject"]
    args = []
    for i, f in enumerate(spec.fields):
        var = f"v{prefix}_{i}"
        env[f"_default{prefix}_{i}"] = functools.partial(default_value, f)
        body.append(f"    {var} = {obj}.get({f.name!r}, Reject)")
        body.append(f"    if {var} is Reject:")
        body.append(f"        {var} = _default{prefix}_{i}()")
        body.append("    else:")
        if not f.is_primitive and not f.is_array and depth < 3:
            inner = _decode_lines(f.base, var, var, env, f"{prefix}_{i}", depth + 1, allow_nonfinite,
                                  lengths_checked)
            body += ["    " + line for line in inner]
        else:
            body += ["        " + line
                     for line in _check_lines(f, var, env, f"{prefix}_{i}", allow_nonfinite, lengths_checked)]
        args.append(var)
    body += ["    " + line for line in equal_length_lines(type_name, prefix, "Reject")]
    body.append(f"    {result} = _cls{prefix}({', '.join(args)})")
    return body


def equal_length_lines(type_name: str, prefix: str, exception: str) -> list[str]:
    """Generated checks of the type's equal-length rule (``EQUAL_LENGTH_RULES``), unindented, for a body that
    holds field ``i``'s value in ``v{prefix}_{i}``; a broken rule raises ``exception``."""
    rule = EQUAL_LENGTH_RULES.get(type_name)
    if not rule:
        return []
    ref, others, empty_ok = rule
    index = {f.name: i for i, f in enumerate(get_spec(type_name).fields)}
    n = f"len(v{prefix}_{index[ref]})"
    lines = []
    for other in others:
        m = f"len(v{prefix}_{index[other]})"
        lines += [f"if {m} != {n}" + (f" and {m} != 0:" if empty_ok else ":"), f"    raise {exception}"]
    return lines


def _check_lines(f: FieldSpec, var: str, env: dict[str, Any], index: str, allow_nonfinite: bool,
                 lengths_checked: bool) -> list[str]:
    fail = ["    raise Reject"]
    if f.is_array:
        size = []
        if f.array_size is not None:
            size.append(f"len({var}) != {f.array_size}")
        if f.upper_bound is not None:
            size.append(f"len({var}) > {f.upper_bound}")
        if f.is_bytes:
            # bin (one object, bounded by the message size, as an image is), or a list of ints the precise
            # decoder converts
            return [f"if type({var}) is not bytes{''.join(' or ' + c for c in size)}:", *fail]
        size.append(f"len({var}) > _MAXLEN")
        lines = [f"if type({var}) is not list or {' or '.join(size)}:", *fail]
        if f.base in FLOAT_TYPES:
            finite = "" if allow_nonfinite else f" or not _isfinite(sum({var}))"
            return lines + [f"if not _FLOAT_ONLY.issuperset(map(type, {var})){finite}:", *fail]
        if f.base in STRING_TYPES:
            if lengths_checked and f.string_bound is None:
                # ''.join type-checks every item in C; unpackb already bounded each string's length
                return lines + ["try:", f"    _join({var})", "except TypeError:", "    raise Reject from None"]
            bound = f.string_bound if f.string_bound is not None else "_MAXSTR"
            return lines + [f"if not _STR_ONLY.issuperset(map(type, {var})) or sum(map(len, {var})) > _MAXSTR"
                            f" or ({var} and max(map(len, {var})) > {bound}):", *fail]
        if f.base in INT_RANGES:
            lo, hi = INT_RANGES[f.base]
            return lines + [f"for x in {var}:", f"    if type(x) is not int or not {lo} <= x <= {hi}:",
                            "        raise Reject"]
        if f.base == "bool":
            return lines + [f"for x in {var}:", "    if type(x) is not bool:", "        raise Reject"]
        name = f"_dec{index}"
        env[name] = _nested(f.base, env)
        return lines + [f"{var} = [{name}(x) for x in {var}]"]
    if f.base in FLOAT_TYPES:
        if allow_nonfinite:
            return [f"if type({var}) is not float:",
                    f"    if type({var}) is not int:", "        raise Reject", f"    {var} = float({var})"]
        return [f"if type({var}) is not float or not -_INF < {var} < _INF:",
                f"    if type({var}) is not int:", "        raise Reject", f"    {var} = float({var})",
                f"    if not -_INF < {var} < _INF:", "        raise Reject"]
    if f.base in INT_RANGES:
        lo, hi = INT_RANGES[f.base]
        return [f"if type({var}) is not int or not {lo} <= {var} <= {hi}:", *fail]
    if f.base == "bool":
        return [f"if type({var}) is not bool:", *fail]
    if f.base in STRING_TYPES:
        if lengths_checked and f.string_bound is None:
            return [f"if type({var}) is not str:", *fail]
        bound = f.string_bound if f.string_bound is not None else "_MAXSTR"
        return [f"if type({var}) is not str or len({var}) > {bound}:", *fail]
    name = f"_dec{index}"
    env[name] = _nested(f.base, env)
    return [f"{var} = {name}({var})"]


def _nested(type_name: str, env: dict[str, Any]) -> Callable[[Any], Any]:
    """The decoder of a nested type with the same limits, resolved on first use (types may recurse)."""
    limits = (env["_MAXLEN"], env["_MAXSTR"], env["_ALLOW_NONFINITE"], env["_LENGTHS_CHECKED"])
    return on_first_use(functools.partial(decoder, type_name, *limits))


def on_first_use(build: Callable[[], Callable[[Any], Any]]) -> Callable[[Any], Any]:
    """A function that calls ``build()``'s result, built on the first call: a nested type's decoder cannot be
    built while the type containing it is (types may recurse)."""
    resolved: list[Callable[[Any], Any]] = []

    def call(v: Any) -> Any:
        if not resolved:
            resolved.append(build())
        return resolved[0](v)

    return call


# ---------------------------------------------------------------- builders (keyword fields -> map)

@functools.cache
def builder(type_name: str) -> Callable[..., dict]:
    """``build(**fields)`` -> the complete msgpack-ready map; absent fields take their ROS defaults.

    Values are trusted (hot paths of our own nodes): lists are used as given, nested messages may be
    maps from another builder or message instances.
    """
    spec = get_spec(type_name)
    env: dict[str, Any] = {"_floats": _floats, "_t": type}   # fields may be called "type"
    params, items = [], []
    for i, f in enumerate(spec.fields):
        default = default_value(f)
        if f.is_primitive and not f.is_array:
            params.append(f"{f.name}={default!r}")
            items.append(f"{f.name!r}: {f.name}")
            continue
        params.append(f"{f.name}=None")
        if f.is_primitive:   # arrays: numpy arrays become lists; None -> the default
            env[f"_d{i}"] = default
            conv = f"_floats({f.name})" if f.base in FLOAT_TYPES and not f.is_bytes else f.name
            items.append(f"{f.name!r}: (_d{i} if {f.name} is None else {conv})")
            continue
        nested = f"_enc_{_ident(f.base)}"
        env[nested] = encoder(f.base)
        env[f"_d{i}"] = _default_map(f)
        if f.is_array:
            items.append(f"{f.name!r}: (_d{i}() if {f.name} is None else "
                         f"[x if _t(x) is dict else {nested}(x) for x in {f.name}])")
        else:
            items.append(f"{f.name!r}: (_d{i}() if {f.name} is None else "
                         f"{f.name} if _t({f.name}) is dict else {nested}({f.name}))")
    source = f"def build(*, {', '.join(params)}):\n    return {{{', '.join(items)}}}"
    return compile_source(source, env, "build", f"builder of {type_name}")


def _default_map(f: FieldSpec) -> Callable[[], Any]:
    enc = encoder(f.base)
    if f.is_array:
        return lambda: [enc(x) for x in default_value(f)]
    return lambda: enc(default_value(f))


@functools.cache
def packer(type_name: str) -> Callable[..., bytes]:
    """``pack(**fields)`` -> msgpack bytes of the complete map (see ``builder``)."""
    build = builder(type_name)

    def packed(**fields: Any) -> bytes:
        return packb(build(**fields))   # a Packer per message: a shared one is not thread-safe

    packed.__doc__ = f"msgpack bytes of a {type_name} from its fields"
    return packed


# ---------------------------------------------------------------- helpers

def compile_source(source: str, env: dict[str, Any], name: str, what: str) -> Callable[..., Any]:
    """Compile generated ``source`` (from parsed definitions only) and return its function ``name``."""
    code = compile(source, f"<{what}>", "exec")
    namespace = dict(env)
    exec(code, namespace)  # noqa: S102 - source generated from parsed definitions, never from user input
    fn = namespace[name]
    fn.__doc__ = f"Generated {what}.\n\n{source}"
    return fn
