"""What ``Message.SLOT_TYPES`` holds: the field types as rosidl_parser.definition spells them.

rosidl_python's generated classes describe each field with an object of ``rosidl_parser.definition``
(``BasicType('double')``, ``UnboundedSequence(NamespacedType(['std_msgs', 'msg'], 'Header'))``...), which generic
code such as rosidl_runtime_py walks. These are the same names, attributes and ``isinstance`` relations, so
that code runs without ROS installed.
"""

from __future__ import annotations

from typing import Any

from msgs.idl import FieldSpec

# .msg primitive -> the IDL type name rosidl uses (rosidl_adapter's MSG_TYPE_TO_IDL)
IDL_NAMES = {
    "bool": "boolean", "byte": "octet", "char": "uint8", "float32": "float", "float64": "double",
    "int8": "int8", "uint8": "uint8", "int16": "int16", "uint16": "uint16", "int32": "int32", "uint32": "uint32",
    "int64": "int64", "uint64": "uint64",
}


class AbstractType:
    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and vars(self) == vars(other)

    def __hash__(self) -> int:
        return hash((type(self).__name__, *sorted((k, repr(v)) for k, v in vars(self).items())))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in vars(self).items())})"


class BasicType(AbstractType):
    def __init__(self, typename: str) -> None:
        self.typename = typename


class NamedType(AbstractType):
    def __init__(self, name: str) -> None:
        self.name = name


class NamespacedType(AbstractType):
    def __init__(self, namespaces: list[str], name: str) -> None:
        self.namespaces = list(namespaces)
        self.name = name

    def namespaced_name(self) -> tuple[str, ...]:
        return (*self.namespaces, self.name)


class AbstractGenericString(AbstractType):
    def __init__(self, maximum_size: int | None = None) -> None:
        self.maximum_size = maximum_size

    def has_maximum_size(self) -> bool:
        return self.maximum_size is not None


class AbstractString(AbstractGenericString):
    pass


class AbstractWString(AbstractGenericString):
    pass


class UnboundedString(AbstractString):
    def __init__(self) -> None:
        super().__init__(None)


class BoundedString(AbstractString):
    pass


class UnboundedWString(AbstractWString):
    def __init__(self) -> None:
        super().__init__(None)


class BoundedWString(AbstractWString):
    pass


class AbstractNestedType(AbstractType):
    def __init__(self, value_type: AbstractType) -> None:
        self.value_type = value_type


class Array(AbstractNestedType):
    def __init__(self, value_type: AbstractType, size: int) -> None:
        super().__init__(value_type)
        self.size = size


class AbstractSequence(AbstractNestedType):
    pass


class UnboundedSequence(AbstractSequence):
    pass


class BoundedSequence(AbstractSequence):
    def __init__(self, value_type: AbstractType, maximum_size: int) -> None:
        super().__init__(value_type)
        self.maximum_size = maximum_size


def _value_type(f: FieldSpec) -> AbstractType:
    if f.base in ("string", "wstring"):
        wide = f.base == "wstring"
        if f.string_bound is None:
            return UnboundedWString() if wide else UnboundedString()
        return (BoundedWString if wide else BoundedString)(f.string_bound)
    if f.is_primitive:
        return BasicType(IDL_NAMES[f.base])
    pkg, kind, name = f.base.split("/")
    return NamespacedType([pkg, kind], name)


def slot_type(f: FieldSpec) -> Any:
    """The rosidl_parser.definition-like object describing field ``f``."""
    value = _value_type(f)
    if not f.is_array:
        return value
    if f.array_size is not None:
        return Array(value, f.array_size)
    if f.upper_bound is not None:
        return BoundedSequence(value, f.upper_bound)
    return UnboundedSequence(value)


def field_type_name(f: FieldSpec) -> str:
    """The field's type as ``get_fields_and_field_types()`` spells it: ``sequence<double>``, ``std_msgs/Header``,
    ``double[9]``, ``string<10>``, ``sequence<int32, 5>``."""
    if f.base in ("string", "wstring"):
        item = f.base + (f"<{f.string_bound}>" if f.string_bound is not None else "")
    elif f.is_primitive:
        item = IDL_NAMES[f.base]
    else:
        pkg, _kind, name = f.base.split("/")
        item = f"{pkg}/{name}"
    if not f.is_array:
        return item
    if f.array_size is not None:
        return f"{item}[{f.array_size}]"
    if f.upper_bound is not None:
        return f"sequence<{item}, {f.upper_bound}>"
    return f"sequence<{item}>"
