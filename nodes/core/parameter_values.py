"""Parameters as ROS 2 types them: Python values <-> rcl_interfaces/ParameterValue, a node's declaration as
a ParameterDescriptor, and rclpy's ``list_parameters`` filter (prefixes, depth).

ROS 2 has nine value types (bool, int64, float64, string, byte[], bool[], int64[], float64[], string[]). A
zenroid value outside them (a map, a nested or mixed list) travels as a string holding its one-line YAML,
and a string sent to a parameter declared as a map or list is read back as YAML.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import msgs
from nodes.core.params import ParameterDescriptor as CoreDescriptor
from nodes.core.params import dump_value, parse_value

ParameterValue = msgs.get_type("rcl_interfaces/msg/ParameterValue")
RosDescriptor = msgs.get_type("rcl_interfaces/msg/ParameterDescriptor")
FloatingPointRange = msgs.get_type("rcl_interfaces/msg/FloatingPointRange")
IntegerRange = msgs.get_type("rcl_interfaces/msg/IntegerRange")
ListParametersResult = msgs.get_type("rcl_interfaces/msg/ListParametersResult")

# rcl_interfaces/msg/ParameterType
NOT_SET, BOOL, INTEGER, DOUBLE, STRING, BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = range(10)
TYPE_NAMES = ("not set", "bool", "integer", "double", "string", "byte_array", "bool_array", "integer_array",
              "double_array", "string_array")
_FIELD = {BOOL: "bool_value", INTEGER: "integer_value", DOUBLE: "double_value", STRING: "string_value",
          BYTE_ARRAY: "byte_array_value", BOOL_ARRAY: "bool_array_value", INTEGER_ARRAY: "integer_array_value",
          DOUBLE_ARRAY: "double_array_value", STRING_ARRAY: "string_array_value"}
_ARRAY_OF = {bool: BOOL_ARRAY, int: INTEGER_ARRAY, float: DOUBLE_ARRAY, str: STRING_ARRAY}
_SCALAR = {bool: BOOL, int: INTEGER, float: DOUBLE, str: STRING}
_INT64 = (-(1 << 63), (1 << 63) - 1)
SEPARATOR = "."


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def type_of(value: Any, empty_list: int = STRING_ARRAY) -> int:
    """The ParameterType of a Python value; ``empty_list`` for ``[]`` (which says nothing about its items).
    STRING for what ROS 2 cannot type (it travels as YAML text)."""
    if value is None:
        return NOT_SET
    if isinstance(value, bool):
        return BOOL
    if _is_int(value):
        return INTEGER if _INT64[0] <= value <= _INT64[1] else STRING
    if isinstance(value, float):
        return DOUBLE
    if isinstance(value, str):
        return STRING
    if isinstance(value, (bytes, bytearray)):
        return BYTE_ARRAY
    if isinstance(value, (list, tuple)):
        if not value:
            return empty_list
        if all(isinstance(x, bool) for x in value):
            return BOOL_ARRAY
        if all(_is_int(x) and _INT64[0] <= x <= _INT64[1] for x in value):
            return INTEGER_ARRAY
        if all(isinstance(x, float) or _is_int(x) for x in value):
            return DOUBLE_ARRAY
        if all(isinstance(x, str) for x in value):
            return STRING_ARRAY
    return STRING


def to_msg(value: Any, empty_list: int = STRING_ARRAY) -> Any:
    """The rcl_interfaces/ParameterValue of a Python value (maps and other untyped values as YAML text)."""
    ptype = type_of(value, empty_list)
    msg = ParameterValue(type=ptype)
    if ptype == NOT_SET:
        return msg
    if ptype == STRING and not isinstance(value, str):
        value = dump_value(value)
    elif ptype == BYTE_ARRAY:
        value = bytes(value)
    elif ptype == DOUBLE_ARRAY:
        value = [float(x) for x in value]
    elif ptype >= BOOL_ARRAY:
        value = list(value)
    setattr(msg, _FIELD[ptype], value)
    return msg


def from_msg(msg: Any) -> Any:
    """The Python value of a ParameterValue (None for NOT_SET; byte[] as bytes). ValueError on an unknown
    type."""
    ptype = msg.type
    if ptype == NOT_SET:
        return None
    field = _FIELD.get(ptype)
    if field is None:
        raise ValueError(f"unknown parameter type {ptype} (rcl_interfaces/ParameterType has 0..9)")
    value = getattr(msg, field)
    if ptype == BYTE_ARRAY:
        return bytes(value)
    return list(value) if ptype > BYTE_ARRAY else value


def declared_type(desc: CoreDescriptor, value: Any) -> int:
    """The ParameterType a zenroid declaration stands for; NOT_SET when it is not typed (``object``)."""
    t = desc.type
    if t in _SCALAR:
        return _SCALAR[t]
    if t is list:
        item = desc.element_type
        if item is None and isinstance(desc.default, list) and desc.default:
            item = float if any(isinstance(x, float) for x in desc.default) else type(desc.default[0])
        if item in _ARRAY_OF:
            return _ARRAY_OF[item]
        return type_of(value, STRING_ARRAY)
    if t is dict:
        return STRING
    return NOT_SET


def value_msg(desc: CoreDescriptor, value: Any) -> Any:
    """A zenroid parameter's value as ROS 2 sees it (an empty list typed by its declaration)."""
    ptype = declared_type(desc, value)
    return to_msg(value, ptype if ptype >= BYTE_ARRAY else STRING_ARRAY)


def from_msg_for(desc: CoreDescriptor, msg: Any) -> Any:
    """A value from ROS 2 for a zenroid parameter: a string for a map or list parameter is YAML, a byte
    array is a list of ints."""
    value = from_msg(msg)
    if isinstance(value, str) and desc.type in (dict, list):
        return parse_value(value)
    if isinstance(value, bytes):
        return list(value)
    return value


def describe(desc: CoreDescriptor, value: Any) -> Any:
    """A zenroid declaration as rcl_interfaces/ParameterDescriptor: type, description, read_only, the
    min/max as a range (step 0: any value between), choices and other checks in additional_constraints."""
    ptype = declared_type(desc, value)
    constraints = []
    if desc.choices is not None:
        constraints.append(f"one of {list(desc.choices)}")
    if desc.validator is not None:
        constraints.append("checked by the node")
    if isinstance(desc.read_only, str):
        constraints.append(f"read-only: {desc.read_only}")
    out = RosDescriptor(name=desc.name, type=ptype, description=desc.description,
                        additional_constraints="; ".join(constraints), read_only=bool(desc.read_only),
                        dynamic_typing=ptype == NOT_SET)
    if desc.min_value is not None or desc.max_value is not None:
        if ptype in (INTEGER, INTEGER_ARRAY):
            low = _INT64[0] if desc.min_value is None else math.ceil(desc.min_value)
            high = _INT64[1] if desc.max_value is None else math.floor(desc.max_value)
            out.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=0)]
        else:
            low = -math.inf if desc.min_value is None else float(desc.min_value)
            high = math.inf if desc.max_value is None else float(desc.max_value)
            out.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
    return out


def list_parameters(names: Iterable[str], prefixes: list[str], depth: int) -> Any:
    """rclpy's ``Node.list_parameters``: the names under any of ``prefixes`` (all when none) at most
    ``depth`` levels below it (0: any depth), and the prefixes of the names returned."""
    result = ListParametersResult()

    def shallow(name: str) -> bool:
        return name.count(SEPARATOR) < depth

    recursive = not prefixes and depth == 0
    for name in names:
        if not recursive and not (not prefixes and shallow(name)):
            if not any(name == p or (name.startswith(p + SEPARATOR) and (depth == 0 or shallow(name[len(p) + 1:])))
                       for p in prefixes):
                continue
        result.names.append(name)
        cut = name.rfind(SEPARATOR)
        if cut != -1 and name[:cut] not in result.prefixes:
            result.prefixes.append(name[:cut])
    return result
