"""Message classes that behave as rosidl_python's generated ones, written from the definitions at run time.

What a ROS 2 program relies on (``rosidl_generator_py``'s ``_msg.py.em``):

- keyword construction with ROS defaults (``JointState(name=["a"])``), an unknown keyword a ``TypeError``;
- fields checked when assigned: a wrong type, an integer out of range, a string or sequence too long raises
  ``FieldTypeError`` / ``FieldValueError`` (both also ``AssertionError``, what Humble raises) naming the type and
  the field; ints are taken for floats and numpy values / arrays for their Python equivalents;
- constants as class attributes, ``get_fields_and_field_types()``, ``SLOT_TYPES``, ``__slots__``, ``==``, and
  ``repr`` spelled ``sensor_msgs.msg.JointState(header=..., ...)``.

Deliberate differences (docs/messages.md): numeric sequences and fixed arrays are Python lists (Jazzy:
``array.array`` and numpy arrays), ``uint8[]``/``byte[]`` are ``bytes``, and ``__slots__`` holds the field names
themselves (rosidl's carry a leading underscore, which would collide with our ``_type`` on Marker's ``type``).

Speed: reading a field is a plain slot read. Only assignment goes through the check (``__setattr__``); the
codec builds decoded messages with ``_make``, which stores already-validated values without checking again.
"""

from __future__ import annotations

import builtins
import keyword
import math
import operator
import re
from collections.abc import Callable
from typing import Any

from msgs.idl import FLOAT_TYPES, INT_RANGES, STRING_TYPES, DefinitionError, FieldSpec, MsgSpec
from msgs.slot_types import field_type_name, slot_type

# the largest float32 exactly: rosidl_python's bound, 3.402823466e+38, is a rounding below it and would refuse
# FLT_MAX itself, which a float32 field holds and the codec sends
_FLOAT32_MAX = 3.4028234663852886e38


class FieldTypeError(TypeError, AssertionError):
    """A value of the wrong type assigned to a message field."""


class FieldValueError(ValueError, AssertionError):
    """A value out of the field's range or bounds (integer range, string or sequence length)."""


_UNSET: Any = type("Unset", (), {"__repr__": lambda self: "<unset>", "__slots__": ()})()


def _kind(v: Any) -> str:
    return getattr(type(v), "_type", None) or type(v).__name__


def _fail(type_name: str, field: str, must: str, v: Any, error: type[Exception] = FieldTypeError) -> Exception:
    shown = repr(v)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    return error(f"{type_name}: the '{field}' field must be {must}, got {_kind(v)} {shown}")


# ---------------------------------------------------------------- conversions of one value (slow paths)

def _as_float(v: Any, t: str, f: str, f32: bool) -> float:
    if isinstance(v, bool) or not isinstance(v, (float, int)) and not _is_numpy_number(v):
        raise _fail(t, f, "a float", v)
    v = float(v)
    if f32 and abs(v) > _FLOAT32_MAX and not math.isinf(v):
        raise _fail(t, f, f"a float in [{-_FLOAT32_MAX}, {_FLOAT32_MAX}]", v, FieldValueError)
    return v


def _as_int(v: Any, t: str, f: str, base: str, lo: int, hi: int) -> int:
    if isinstance(v, float) or not isinstance(v, int) and not _is_numpy_integer(v):
        raise _fail(t, f, f"an integer ({base})", v)
    v = operator.index(v)
    if not lo <= v <= hi:
        raise _fail(t, f, f"an integer in [{lo}, {hi}] ({base})", v, FieldValueError)
    return v


def _as_bool(v: Any, t: str, f: str) -> bool:
    if type(v).__name__ == "bool_":   # numpy.bool_
        return bool(v)
    raise _fail(t, f, "a bool", v)


def _as_str(v: Any, t: str, f: str, bound: int | None) -> str:
    if not isinstance(v, str):
        raise _fail(t, f, "a str", v)
    v = str(v)
    if bound is not None and len(v) > bound:
        raise _fail(t, f, f"a str of at most {bound} characters", v, FieldValueError)
    return v


def _as_message(v: Any, cls: type, t: str, f: str) -> Any:
    if isinstance(v, cls):
        return v
    raise _fail(t, f, f"a sub message of type '{cls._type}'", v)


def _is_numpy_number(v: Any) -> bool:
    return type(v).__module__ == "numpy" and hasattr(v, "dtype") and v.dtype.kind in "fiu"


def _is_numpy_integer(v: Any) -> bool:
    return type(v).__module__ == "numpy" and hasattr(v, "dtype") and v.dtype.kind in "iu"


def _as_list(v: Any, t: str, f: str, what: str, size: int | None, bound: int | None) -> list:
    """Any sequence (list, tuple, array.array, numpy array...) as a new list, its length checked."""
    if isinstance(v, (str, bytes, bytearray, dict)) or not hasattr(v, "__len__") or not hasattr(v, "__iter__"):
        raise _fail(t, f, what, v)
    items = v.tolist() if hasattr(v, "tolist") else list(v)
    if size is not None and len(items) != size:
        raise _fail(t, f, f"{what} of exactly {size} items", v, FieldValueError)
    if bound is not None and len(items) > bound:
        raise _fail(t, f, f"{what} of at most {bound} items", v, FieldValueError)
    return items


def _each(items: list, convert: Callable[[Any, str, str], Any], t: str, f: str) -> list:
    for i, x in enumerate(items):
        items[i] = convert(x, t, f"{f}[{i}]")
    return items


def _as_bytes(v: Any, t: str, f: str, size: int | None, bound: int | None) -> bytes:
    if isinstance(v, str) or not isinstance(v, (bytes, bytearray, memoryview)) and not hasattr(v, "__iter__"):
        raise _fail(t, f, "bytes (or a sequence of integers in [0, 255])", v)
    try:
        data = v.tobytes() if hasattr(v, "tobytes") and getattr(v, "itemsize", 1) == 1 else bytes(v)
    except (TypeError, ValueError):
        raise _fail(t, f, "bytes (or a sequence of integers in [0, 255])", v) from None
    if size is not None and len(data) != size:
        raise _fail(t, f, f"exactly {size} bytes", v, FieldValueError)
    if bound is not None and len(data) > bound:
        raise _fail(t, f, f"at most {bound} bytes", v, FieldValueError)
    return data


# ---------------------------------------------------------------- the class

def _setter_lines(i: int, f: FieldSpec, env: dict[str, Any]) -> list[str]:
    """The body of ``_set{i}(self, v)``: fast acceptance of the exact type, else the converting check."""
    size, bound = f.array_size, f.upper_bound
    length = (f" or len(v) != {size}" if size is not None else "") + (f" or len(v) > {bound}" if bound is not None
                                                                       else "")
    name = repr(f.name)
    if f.is_bytes:
        return [f"if type(v) is not bytes{length}:", f"    v = _as_bytes(v, _T, {name}, {size}, {bound})"]
    if f.is_array:
        item = f"_item{i}"
        if f.base in FLOAT_TYPES:
            env[item] = lambda x, t, p, f32=f.base == "float32": _as_float(x, t, p, f32)
            fast = "_FLOAT_ONLY.issuperset(map(type, v))"
        elif f.base in INT_RANGES:
            lo, hi = INT_RANGES[f.base]
            env[item] = lambda x, t, p, base=f.base, lo=lo, hi=hi: _as_int(x, t, p, base, lo, hi)
            fast = f"_INT_ONLY.issuperset(map(type, v)) and (not v or {lo} <= min(v) and max(v) <= {hi})"
        elif f.base == "bool":
            env[item] = _as_bool_item
            fast = "_BOOL_ONLY.issuperset(map(type, v))"
        elif f.base in STRING_TYPES:
            env[item] = lambda x, t, p, b=f.string_bound: _as_str(x, t, p, b)
            fast = "_STR_ONLY.issuperset(map(type, v))" + (
                f" and (not v or max(map(len, v)) <= {f.string_bound})" if f.string_bound is not None else "")
        else:
            env[item] = lambda x, t, p, n=f"_C{i}": _as_message(x, env[n], t, p)
            env[f"_ONLY{i}"] = None   # {nested class}, set when the nested class is resolved
            fast = f"_ONLY{i}.issuperset(map(type, v))"
        what = f"a sequence ({field_type_name(f)})"
        return [f"if type(v) is not list or not ({fast}){length}:",
                f"    v = _each(_as_list(v, _T, {name}, {what!r}, {size}, {bound}), {item}, _T, {name})"]
    if f.base in FLOAT_TYPES:
        if f.base == "float32":
            return [f"if type(v) is not float or not -{_FLOAT32_MAX!r} <= v <= {_FLOAT32_MAX!r}:",
                    f"    v = _as_float(v, _T, {name}, True)"]
        return ["if type(v) is not float:", f"    v = _as_float(v, _T, {name}, False)"]
    if f.base in INT_RANGES:
        lo, hi = INT_RANGES[f.base]
        return [f"if type(v) is not int or not {lo} <= v <= {hi}:",
                f"    v = _as_int(v, _T, {name}, {f.base!r}, {lo}, {hi})"]
    if f.base == "bool":
        return ["if type(v) is not bool:", f"    v = _as_bool(v, _T, {name})"]
    if f.base in STRING_TYPES:
        check = f" or len(v) > {f.string_bound}" if f.string_bound is not None else ""
        return [f"if type(v) is not str{check}:", f"    v = _as_str(v, _T, {name}, {f.string_bound})"]
    return [f"if type(v) is not _C{i}:", f"    v = _as_message(v, _C{i}, _T, {name})"]


_BUILTINS = ("type", "len", "map", "max", "min", "list", "float", "int", "bool", "str", "bytes")
_NAMES = re.compile(r"\b(v|" + "|".join(_BUILTINS) + r")\b")


def _unshadowed(line: str) -> str:
    """A setter line for ``__init__``, whose parameters are the field names (a field may be called ``type``,
    ``min`` or ``v``): the value is ``_v`` and the builtins are ``_b_<name>`` (quoted text left as it is)."""
    parts = line.split("'")
    for k in range(0, len(parts), 2):   # outside quotes
        parts[k] = _NAMES.sub(lambda m: "_v" if m.group(1) == "v" else f"_b_{m.group(1)}", parts[k])
    return "'".join(parts)


def _as_bool_item(x: Any, t: str, p: str) -> bool:
    return x if type(x) is bool else _as_bool(x, t, p)


def _default_expr(i: int, f: FieldSpec, env: dict[str, Any], default: Callable[[FieldSpec], Any]) -> str:
    """Python source for a fresh default value of field ``i`` (constants inline, mutable values new)."""
    if f.is_primitive:
        value = default(f)
        if isinstance(value, list):
            env[f"_D{i}"] = tuple(value)
            return f"list(_D{i})"
        env[f"_D{i}"] = value   # immutable: float, int, bool, str, bytes
        return f"_D{i}"
    if f.is_array:
        if f.array_size:
            return f"[_C{i}() for _ in range({f.array_size})]"
        return "[]"
    return f"_C{i}()"


def make_class(spec: MsgSpec, default: Callable[[FieldSpec], Any]) -> tuple[type, Callable[[Callable[[str], Any]],
                                                                                            None]]:
    """The class of ``spec`` and ``resolve(get_class)``, to call once the class is registered: it binds the
    nested message classes (looked up then, so types may refer to each other)."""
    type_name = spec.type_name
    pkg, kind, name = type_name.split("/")
    fields = spec.fields
    for f in fields:
        if keyword.iskeyword(f.name):
            raise DefinitionError(f"{type_name}: field '{f.name}' is a Python keyword (rosidl_python refuses it too)")
    env: dict[str, Any] = {
        "_T": type_name, "_new": object.__new__, "_UNSET": _UNSET, "_as_float": _as_float, "_as_int": _as_int,
        "_as_bool": _as_bool, "_as_str": _as_str, "_as_message": _as_message, "_as_bytes": _as_bytes,
        "_as_list": _as_list, "_each": _each, "_FLOAT_ONLY": frozenset({float}), "_INT_ONLY": frozenset({int}),
        "_BOOL_ONLY": frozenset({bool}), "_STR_ONLY": frozenset({str}),
        **{f"_b_{name}": getattr(builtins, name) for name in _BUILTINS},
    }
    lines = [f"class {name}:", f"    __slots__ = {tuple(f.name for f in fields)!r}"]
    params = ", ".join(f"{f.name}=_UNSET" for f in fields)
    # internal names start with "_": ROS field names cannot, so none is shadowed by a field
    lines.append(f"    def __init__(_self, *, {params + ', ' if params else ''}check_fields=None):")
    for i, f in enumerate(fields):
        # the setter's checks inline (a call per field would cost the construction more than the checks)
        checks = [_unshadowed(line) for line in _setter_lines(i, f, env)]
        lines += [f"        if {f.name} is _UNSET:", f"            _s{i}(_self, {_default_expr(i, f, env, default)})",
                  "        else:", f"            _v = {f.name}", *(f"            {line}" for line in checks),
                  f"            _s{i}(_self, _v)"]
    lines.append("        return None")
    # __setattr__: the one way a field changes after construction (slots admit no other attribute)
    lines += ["    def __setattr__(self, name, value):", "        setter = _SETTERS.get(name)", "        if setter is None:",
              "            raise AttributeError(f\"'{type(self).__name__}' object has no field '{name}' ({_T})\")",
              "        setter(self, value)"]
    compare = " and ".join(f"self.{f.name} == other.{f.name}" for f in fields) or "True"
    lines += ["    def __eq__(self, other):", "        if other.__class__ is not self.__class__:", "            return False",
              f"        return {compare}", "    __hash__ = None"]
    lines += ["    def __copy__(self):", f"        return _make({', '.join(f'self.{f.name}' for f in fields)})"]
    shown = ", ".join(f"{f.name}={{self.{f.name}!r}}" for f in fields)
    lines += ["    def __repr__(self):", f"        return f'{pkg}.{kind}.{name}({shown})'"]
    lines += ["    @classmethod", "    def get_fields_and_field_types(cls):", "        return dict(cls._fields_and_field_types)"]
    for i, f in enumerate(fields):
        lines += [f"def _set{i}(self, v):", *("    " + line for line in _setter_lines(i, f, env)), f"    _s{i}(self, v)"]
    args = ", ".join(f.name for f in fields)
    lines += [f"def _make({args}):", "    _o = _new(_CLS)", *(f"    _s{i}(_o, {f.name})" for i, f in enumerate(fields)),
              "    return _o"]
    source = "\n".join(lines)
    namespace_env = dict(env)
    code = compile(source, f"<message class {type_name}>", "exec")
    exec(code, namespace_env)  # noqa: S102 - source generated from parsed definitions (identifiers only)
    cls = namespace_env[name]
    for i, f in enumerate(fields):
        namespace_env[f"_s{i}"] = cls.__dict__[f.name].__set__
    namespace_env["_CLS"] = cls
    namespace_env["_SETTERS"] = {f.name: namespace_env[f"_set{i}"] for i, f in enumerate(fields)}
    for constant, value in spec.constants.items():
        setattr_type(cls, constant, value)
    setattr_type(cls, "_type", type_name)
    setattr_type(cls, "_spec", spec)
    setattr_type(cls, "_fields_and_field_types", {f.name: field_type_name(f) for f in fields})
    setattr_type(cls, "SLOT_TYPES", tuple(slot_type(f) for f in fields))
    _makers[cls] = namespace_env["_make"]
    cls.__module__ = f"msgs.{pkg}"
    cls.__qualname__ = name
    cls.__doc__ = f"{type_name}\n\n{spec.text}"
    cls.__init__.__doc__ = f"A {type_name}; every field a keyword, absent ones take their ROS default."

    def resolve(get_class: Callable[[str], Any]) -> None:
        for i, f in enumerate(fields):
            if not f.is_primitive:
                nested = get_class(f.base)
                namespace_env[f"_C{i}"] = nested
                if f"_ONLY{i}" in namespace_env:
                    namespace_env[f"_ONLY{i}"] = frozenset({nested})

    return cls, resolve


_makers: dict[type, Callable[..., Any]] = {}


def maker(cls: type) -> Callable[..., Any]:
    """The codec's constructor of ``cls``: the field values, positional in field order (or by name), already
    valid, stored as they are without a second check."""
    return _makers[cls]


def setattr_type(cls: type, name: str, value: Any) -> None:
    """A class attribute (``type.__setattr__``: the class's own ``__setattr__`` guards instances only)."""
    type.__setattr__(cls, name, value)
