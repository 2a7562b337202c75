"""CDR (the ROS 2 / DDS wire format) for our message definitions, from and to plain data.

Plain data is what msgpack carries (docs/architecture.md, Messages on the wire): nested dicts with ROS field names, lists, ``bytes`` for
``uint8[]``. A missing field encodes as its ROS default, so the hot paths that pack partial maps still
produce complete CDR. Encapsulation is little-endian plain CDR (``00 01 00 00``), alignment relative to the
payload start, 8-byte types aligned to 8, exactly as Fast-CDR (rmw_zenoh, rmw_fastrtps) writes it.

Per type, an encoder and a decoder are generated as straight-line Python from the parsed definition
(field names are validated identifiers and only appear as string literals), because an interpreting
walker costs several times more per message (bench/ros2_wire.py: joint_states at 1 kHz).
Compatibility is tested against rosbags' independent CDR implementation.
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Callable
from typing import Any

from msgs.idl import FieldSpec
from msgs.registry import get_spec

HEADER = b"\x00\x01\x00\x00"  # CDR_LE encapsulation, options 0

_FORMATS = {
    "bool": "?", "int8": "b", "uint8": "B", "byte": "B", "char": "B", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d",
}
_ZERO = {"bool": "False", "float32": "0.0", "float64": "0.0", "string": "''", "wstring": "''"}
_PAD = tuple(b"\x00" * n for n in range(8))
_STRINGS = ("string", "wstring")


class CdrError(ValueError):
    """A payload that is not valid CDR of the expected type, or data that cannot be encoded."""


def _size(base: str) -> int:
    return struct.calcsize("<" + _FORMATS[base])


class _Source:
    """Generated source lines with indentation and a table of constants the code refers to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.consts: list[Any] = []
        self.counter = 0

    def emit(self, depth: int, line: str) -> None:
        self.lines.append("    " * depth + line)

    def const(self, value: Any) -> str:
        self.consts.append(value)
        return f"_C[{len(self.consts) - 1}]"

    def var(self, stem: str) -> str:
        self.counter += 1
        return f"{stem}{self.counter}"


def _default_expr(src: _Source, f: FieldSpec) -> str:
    if f.default is not None:
        return src.const(f.default)
    if f.is_array:
        return "()"
    if not f.is_primitive:
        return "_EMPTY"
    return _ZERO.get(f.base, "0")


# ---------------------------------------------------------------- one value, either way

def _align(src: _Source, depth: int, size: int) -> None:
    if size > 1:
        src.emit(depth, f"out += _PAD[(4 - len(out)) & {size - 1}]")


def _dalign(src: _Source, depth: int, size: int) -> None:
    if size > 1:
        src.emit(depth, f"p += (4 - p) & {size - 1}")


def _enc_string(src: _Source, depth: int, _base: str, value: str) -> None:
    raw = src.var("s")
    src.emit(depth, f"{raw} = {value}.encode()")
    _align(src, depth, 4)
    src.emit(depth, f"out += _U32(len({raw}) + 1)")
    src.emit(depth, f"out += {raw}")
    src.emit(depth, "out.append(0)")


def _dec_string(src: _Source, depth: int, _base: str, target: str) -> None:
    n = src.var("n")
    _dalign(src, depth, 4)
    src.emit(depth, f"{n}, = _unpack_from('<I', b, p)")
    src.emit(depth, f"if {n} == 0 or p + 4 + {n} > len(b): raise CdrError('bad string length')")
    src.emit(depth, f"{target} = b[p + 4:p + 3 + {n}].decode()")
    src.emit(depth, f"p += 4 + {n}")


def _enc_primitive(src: _Source, depth: int, base: str, value: str) -> None:
    _align(src, depth, _size(base))
    src.emit(depth, f"out += _pack('<{_FORMATS[base]}', {value})")


def _dec_primitive(src: _Source, depth: int, base: str, target: str) -> None:
    _dalign(src, depth, _size(base))
    src.emit(depth, f"{target}, = _unpack_from('<{_FORMATS[base]}', b, p)")
    src.emit(depth, f"p += {_size(base)}")


_ENCODE, _DECODE = 0, 1
# How one value of each kind is written (value: an expression) and read (target: where it goes).
_ONE_VALUE: dict[str, tuple[Callable[[_Source, int, str, str], None], ...]] = {
    "string": (_enc_string, _dec_string),
    "primitive": (_enc_primitive, _dec_primitive),
    "nested": (lambda src, depth, base, value: src.emit(depth, f"_enc[{base!r}]({value}, out)"),
               lambda src, depth, base, target: src.emit(depth, f"{target}, p = _dec[{base!r}](b, p)")),
}


def _one_value(src: _Source, depth: int, base: str, slot: str, direction: int) -> None:
    """Code for one value of type ``base``: a fixed-size primitive, a string or a nested message."""
    kind = "string" if base in _STRINGS else "primitive" if base in _FORMATS else "nested"
    _ONE_VALUE[kind][direction](src, depth, base, slot)


def _field(src: _Source, depth: int, f: FieldSpec, slot: str, direction: int) -> None:
    if f.is_array:
        (_enc_array, _dec_array)[direction](src, depth, f, slot)
    else:
        _one_value(src, depth, f.base, slot, direction)


# ---------------------------------------------------------------- encoder

def _enc_array(src: _Source, depth: int, f: FieldSpec, value: str) -> None:
    base = f.base
    items = src.var("a")
    src.emit(depth, f"{items} = {value}")
    if f.array_size is None:  # sequence: uint32 count first
        _align(src, depth, 4)
        src.emit(depth, f"out += _U32(len({items}))")
        if f.upper_bound is not None:
            src.emit(depth, f"if len({items}) > {f.upper_bound}: raise CdrError('{f.name}: more than "
                            f"{f.upper_bound} elements')")
    else:
        src.emit(depth, f"if len({items}) != {f.array_size}: raise CdrError('{f.name}: needs exactly "
                        f"{f.array_size} elements')")
    if base in _FORMATS:  # primitive arrays in one go
        if base in ("uint8", "byte", "char"):
            src.emit(depth, f"out += bytes({items})")
            return
        src.emit(depth, f"if {items}:")
        _align(src, depth + 1, _size(base))
        src.emit(depth + 1, f"out += _pack('<%d{_FORMATS[base]}' % len({items}), *{items})")
        return
    item = src.var("e")
    src.emit(depth, f"for {item} in {items}:")
    _one_value(src, depth + 1, base, item, _ENCODE)


def _build_encoder(type_name: str) -> Callable[[dict, bytearray], None]:
    spec = get_spec(type_name)
    src = _Source()
    src.emit(0, "def encode(d, out):")
    if not spec.fields:
        src.emit(1, "out.append(0)  # structure_needs_at_least_one_member")
    for f in spec.fields:
        _field(src, 1, f, f"d.get({f.name!r}, {_default_expr(src, f)})", _ENCODE)
    return _compile(src, "encode")


# ---------------------------------------------------------------- decoder

def _dec_array(src: _Source, depth: int, f: FieldSpec, target: str) -> None:
    base = f.base
    count = src.var("c")
    if f.array_size is None:
        _dalign(src, depth, 4)
        src.emit(depth, f"{count}, = _unpack_from('<I', b, p)")
        src.emit(depth, "p += 4")
        src.emit(depth, f"if {count} > len(b) - p: raise CdrError('{f.name}: sequence longer than the payload')")
    else:
        src.emit(depth, f"{count} = {f.array_size}")
    if base in _FORMATS:  # primitive arrays in one go
        if base in ("uint8", "byte", "char"):
            src.emit(depth, f"if p + {count} > len(b): raise CdrError('{f.name}: truncated')")
            src.emit(depth, f"{target} = bytes(b[p:p + {count}])")
            src.emit(depth, f"p += {count}")
            return
        size = _size(base)
        src.emit(depth, f"if {count}:")
        _dalign(src, depth + 1, size)
        src.emit(depth + 1, f"{target} = list(_unpack_from('<%d{_FORMATS[base]}' % {count}, b, p))")
        src.emit(depth + 1, f"p += {size} * {count}")
        src.emit(depth, "else:")
        src.emit(depth + 1, f"{target} = []")
        return
    items, item = src.var("l"), src.var("x")
    src.emit(depth, f"{items} = []")
    src.emit(depth, f"for _ in range({count}):")
    _one_value(src, depth + 1, base, item, _DECODE)
    src.emit(depth + 1, f"{items}.append({item})")
    src.emit(depth, f"{target} = {items}")


def _build_decoder(type_name: str) -> Callable[[bytes, int], tuple[dict, int]]:
    spec = get_spec(type_name)
    src = _Source()
    src.emit(0, "def decode(b, p):")
    src.emit(1, "d = {}")
    if not spec.fields:
        src.emit(1, "p += 1  # structure_needs_at_least_one_member")
    for f in spec.fields:
        _field(src, 1, f, f"d[{f.name!r}]", _DECODE)
    src.emit(1, "return d, p")
    return _compile(src, "decode")


# ---------------------------------------------------------------- compile, cache, API

_enc: dict[str, Callable] = {}
_dec: dict[str, Callable] = {}
_lock = threading.RLock()


class _LazyTable(dict):
    """Nested types compile on first use (recursive definitions stay finite)."""

    def __init__(self, build: Callable[[str], Callable]) -> None:
        super().__init__()
        self._build = build

    def __missing__(self, type_name: str) -> Callable:
        with _lock:
            if type_name not in self:
                self[type_name] = self._build(type_name)
            return self[type_name]


def _compile(src: _Source, name: str) -> Callable:
    namespace: dict[str, Any] = {
        "_C": src.consts, "_PAD": _PAD, "_U32": struct.Struct("<I").pack, "_pack": struct.pack,
        "_unpack_from": struct.unpack_from, "_EMPTY": {}, "_enc": _encoders, "_dec": _decoders,
        "CdrError": CdrError,
    }
    exec(compile("\n".join(src.lines), f"<cdr {name}>", "exec"), namespace)  # noqa: S102 - generated code only
    return namespace[name]


_encoders: _LazyTable = _LazyTable(_build_encoder)
_decoders: _LazyTable = _LazyTable(_build_decoder)


def encode(type_name: str, data: dict) -> bytes:
    """CDR bytes (with encapsulation header) of plain ``data`` of ``type_name`` ("pkg/msg/Name")."""
    out = bytearray(HEADER)
    try:
        _encoders[type_name](data, out)
    except CdrError as exc:
        raise CdrError(f"{type_name}: {exc}") from None
    except (struct.error, TypeError, AttributeError, UnicodeError, ValueError) as exc:
        raise CdrError(f"{type_name}: cannot encode: {exc}") from None
    return bytes(out)


def decode(type_name: str, payload: bytes) -> dict:
    """Plain data of a CDR payload of ``type_name``; raises CdrError on anything malformed."""
    if len(payload) < 4 or payload[1] != 1 or payload[0] != 0:
        raise CdrError(f"{type_name}: not little-endian CDR (encapsulation {bytes(payload[:4]).hex() or 'missing'})")
    try:
        data, _ = _decoders[type_name](payload, 4)
    except CdrError as exc:
        raise CdrError(f"{type_name}: {exc}") from None
    except (struct.error, UnicodeError, IndexError) as exc:
        raise CdrError(f"{type_name}: truncated or malformed CDR: {exc}") from None
    return data
