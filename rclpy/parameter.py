"""``Parameter`` as rclpy has it: a name, a ``Parameter.Type`` and a value; conversions to and from
rcl_interfaces messages when those types are known."""

from __future__ import annotations

import array
from enum import Enum
from typing import Any

from rclpy.exceptions import InvalidParameterTypeException

PARAMETER_SEPARATOR_STRING = "."


_FIELDS = {
    "ParameterValue": dict(type=0, bool_value=False, integer_value=0, double_value=0.0, string_value="",
                           byte_array_value=[], bool_array_value=[], integer_array_value=[],
                           double_array_value=[], string_array_value=[]),
    "Parameter": dict(name="", value=None),
}


def _msg(name: str) -> Any:
    """An rcl_interfaces message class, or a stand-in with its fields when the definitions lack it."""
    import msgs

    try:
        return msgs.get_type(f"rcl_interfaces/msg/{name}")
    except Exception:  # noqa: BLE001 - older definitions
        defaults = _FIELDS[name]

        def make(**fields: Any) -> Any:
            import copy
            from types import SimpleNamespace

            return SimpleNamespace(**{**copy.deepcopy(defaults), **fields})

        return make


class Parameter:
    class Type(Enum):
        NOT_SET = 0
        BOOL = 1
        INTEGER = 2
        DOUBLE = 3
        STRING = 4
        BYTE_ARRAY = 5
        BOOL_ARRAY = 6
        INTEGER_ARRAY = 7
        DOUBLE_ARRAY = 8
        STRING_ARRAY = 9

        @classmethod
        def from_parameter_value(cls, value: Any) -> Parameter.Type:
            if value is None:
                return cls.NOT_SET
            if isinstance(value, bool):
                return cls.BOOL
            if isinstance(value, int):
                return cls.INTEGER
            if isinstance(value, float):
                return cls.DOUBLE
            if isinstance(value, str):
                return cls.STRING
            if isinstance(value, (bytes, bytearray)):
                return cls.BYTE_ARRAY
            if isinstance(value, array.array):
                if value.typecode in ("d", "f"):
                    return cls.DOUBLE_ARRAY
                return cls.INTEGER_ARRAY
            if isinstance(value, (list, tuple)):
                if all(isinstance(v, bytes) for v in value) and value:
                    return cls.BYTE_ARRAY
                if all(isinstance(v, bool) for v in value):
                    return cls.BOOL_ARRAY
                if all(isinstance(v, int) and not isinstance(v, bool) for v in value):
                    return cls.INTEGER_ARRAY
                if all(isinstance(v, float) for v in value):
                    return cls.DOUBLE_ARRAY
                if all(isinstance(v, str) for v in value):
                    return cls.STRING_ARRAY
            raise TypeError(f"The given value is not one of the allowed types '{value}'.")

        def check(self, value: Any) -> bool:
            T = Parameter.Type
            if self == T.NOT_SET:
                return value is None
            if self == T.BOOL:
                return isinstance(value, bool)
            if self == T.INTEGER:
                return isinstance(value, int) and not isinstance(value, bool)
            if self == T.DOUBLE:
                return isinstance(value, float)
            if self == T.STRING:
                return isinstance(value, str)
            if self == T.BYTE_ARRAY:
                return isinstance(value, (bytes, bytearray, list, tuple)) and \
                    all(isinstance(v, (bytes, int)) for v in value)
            if not isinstance(value, (list, tuple, array.array)):
                return False
            item = {T.BOOL_ARRAY: bool, T.INTEGER_ARRAY: int, T.DOUBLE_ARRAY: float, T.STRING_ARRAY: str}[self]
            return all(isinstance(v, item) and (item is bool or not isinstance(v, bool)) for v in value)

    def __init__(self, name: str, type_: Parameter.Type | None = None, value: Any = None) -> None:
        if type_ is None:
            type_ = Parameter.Type.from_parameter_value(value)
        if not isinstance(type_, Parameter.Type):
            raise TypeError(f"type must be an instance of '{repr(Parameter.Type)}'")
        if not type_.check(value):
            raise ValueError(f"Type '{type_}' and value '{value}' do not agree")
        self._type_ = type_
        self._name = name
        self._value = value

    @property
    def name(self) -> str:
        return self._name

    @property
    def type_(self) -> Parameter.Type:
        return self._type_

    @property
    def value(self) -> Any:
        return self._value

    def __repr__(self) -> str:
        return f"Parameter(name={self._name!r}, type_={self._type_}, value={self._value!r})"

    def get_parameter_value(self) -> Any:
        value = _msg("ParameterValue")(type=self._type_.value)
        T = Parameter.Type
        field = {T.BOOL: "bool_value", T.INTEGER: "integer_value", T.DOUBLE: "double_value",
                 T.STRING: "string_value", T.BYTE_ARRAY: "byte_array_value", T.BOOL_ARRAY: "bool_array_value",
                 T.INTEGER_ARRAY: "integer_array_value", T.DOUBLE_ARRAY: "double_array_value",
                 T.STRING_ARRAY: "string_array_value"}.get(self._type_)
        if field is not None:
            data = self._value
            if self._type_ == T.BYTE_ARRAY and isinstance(data, (list, tuple)):   # rclpy's: a list of bytes
                data = b"".join(x if isinstance(x, bytes) else bytes([x]) for x in data)
            setattr(value, field, list(data) if isinstance(data, (tuple, array.array)) else data)
        return value

    def to_parameter_msg(self) -> Any:
        return _msg("Parameter")(name=self._name, value=self.get_parameter_value())

    @classmethod
    def from_parameter_msg(cls, param_msg: Any) -> Parameter:
        return cls(param_msg.name, Parameter.Type(param_msg.value.type),
                   parameter_value_to_python(param_msg.value))


def parameter_value_to_python(parameter_value: Any) -> Any:
    """The Python value of an rcl_interfaces/ParameterValue."""
    t = parameter_value.type
    fields = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value", 5: "byte_array_value",
              6: "bool_array_value", 7: "integer_array_value", 8: "double_array_value", 9: "string_array_value"}
    if t == 0:
        return None
    if t not in fields:
        raise RuntimeError(f"unexpected parameter type {t}")
    value = getattr(parameter_value, fields[t])
    return list(value) if t >= 5 else value


def get_parameter_value(string_value: str) -> Any:
    """A ParameterValue from text (YAML, as ``ros2 param set``)."""
    from nodes.core.params import parse_value

    value = parse_value(string_value)
    try:
        return Parameter("x", value=value).get_parameter_value()
    except (TypeError, ValueError):
        return Parameter("x", value=string_value).get_parameter_value()


def parameter_dict_from_yaml_file(parameter_file: str, use_wildcard: bool = False,
                                  target_nodes: list[str] | None = None, namespace: str = "") -> dict[str, Any]:
    from nodes.core.params import load_params_file

    values: dict[str, Any] = {}
    for node in target_nodes or ["/**"]:
        values.update(load_params_file(parameter_file, node.lstrip("/"), namespace))
    return {name: Parameter(name, value=value) for name, value in values.items() if not isinstance(value, dict)}


def check_value(parameter: Parameter, expected: Parameter.Type) -> None:
    if parameter.type_ != expected:
        raise InvalidParameterTypeException(parameter, parameter.type_.name)
