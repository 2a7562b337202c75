"""Declared controller parameters: type, default, range/choices, validation (generate_parameter_library style).

Controllers live inside the controller manager, so their parameters are not node parameters: they come
from the controller's ``<name>: ros__parameters:`` block (nested maps are flattened to dotted names, the
way ROS 2 stores ``constraints.joint1.goal``) and are checked when the controller is configured.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any


class ParameterError(ValueError):
    """A parameter value is missing, of the wrong type or out of range; the message names it."""


def flatten(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"constraints": {"joint1": {"goal": 0.01}}}`` -> ``{"constraints.joint1.goal": 0.01}``."""
    flat: dict[str, Any] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(flatten(value, f"{name}."))
        else:
            flat[name] = value
    return flat


@dataclass
class ParamSpec:
    name: str
    default: Any
    type: type
    description: str = ""
    min_value: float | None = None
    max_value: float | None = None
    choices: tuple | None = None
    validator: Callable[[Any], str | None] | None = None  # returns an error reason or None
    element_type: type | None = None  # for lists


def _type_name(t: type) -> str:
    return {float: "double", int: "integer", bool: "bool", str: "string", list: "array"}.get(t, t.__name__)


def coerce(spec: ParamSpec, value: Any) -> Any:
    """Check ``value`` against ``spec`` and return it in the declared type; ParameterError otherwise."""
    where = f"parameter '{spec.name}'"
    if spec.type is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(f"{where}: expected a number, got {value!r}")
        value = float(value)
        if math.isnan(value):  # infinity is allowed: it means "no limit" for clamps
            raise ParameterError(f"{where}: must be a number, got NaN")
    elif spec.type is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ParameterError(f"{where}: expected an integer, got {value!r}")
    elif spec.type is bool:
        if not isinstance(value, bool):
            raise ParameterError(f"{where}: expected true/false, got {value!r}")
    elif spec.type is str:
        if not isinstance(value, str):
            raise ParameterError(f"{where}: expected a string, got {value!r}")
    elif spec.type is list:
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            raise ParameterError(f"{where}: expected a list, got {value!r}")
        value = list(value)
        if spec.element_type is not None:
            for i, item in enumerate(value):
                ok = isinstance(item, spec.element_type) and not isinstance(item, bool)
                if spec.element_type is float and isinstance(item, int) and not isinstance(item, bool):
                    ok, value[i] = True, float(item)
                if not ok:
                    raise ParameterError(
                        f"{where}[{i}]: expected {_type_name(spec.element_type)}, got {item!r}")
    if spec.min_value is not None and value < spec.min_value:
        raise ParameterError(f"{where}: {value} is below the minimum {spec.min_value}")
    if spec.max_value is not None and value > spec.max_value:
        raise ParameterError(f"{where}: {value} is above the maximum {spec.max_value}")
    if spec.choices is not None:
        items = value if isinstance(value, list) else [value]
        for item in items:
            if item not in spec.choices:
                raise ParameterError(f"{where}: '{item}' is not one of {list(spec.choices)}")
    if spec.validator is not None:
        reason = spec.validator(value)
        if reason:
            raise ParameterError(f"{where}: {reason}")
    return value


class Parameters:
    """The declared parameters of one controller and their current values."""

    def __init__(self, controller_name: str) -> None:
        self.controller_name = controller_name
        self.specs: dict[str, ParamSpec] = {}
        self.values: dict[str, Any] = {}
        self._overrides: dict[str, Any] = {}

    def set_overrides(self, raw: Mapping[str, Any]) -> None:
        """Values from YAML (nested or dotted); applied to declarations made before or after."""
        self._overrides = flatten(raw)
        for name, spec in self.specs.items():
            if name in self._overrides:
                self.values[name] = coerce(spec, self._overrides[name])

    def declare(self, name: str, default: Any, *, type: type | None = None, description: str = "",
                min_value: float | None = None, max_value: float | None = None,
                choices: tuple | list | None = None, validator: Callable[[Any], str | None] | None = None,
                element_type: type | None = None) -> Any:
        declared_type = type or (float if isinstance(default, float) else builtin_type(default))
        if declared_type is list and element_type is None and default:
            element_type = builtin_type(default[0])
        spec = ParamSpec(name, default, declared_type, description, min_value, max_value,
                         tuple(choices) if choices is not None else None, validator, element_type)
        self.specs[name] = spec
        raw = self._overrides.get(name, default)
        self.values[name] = coerce(spec, raw) if raw is not None else None
        return self.values[name]

    def get(self, name: str) -> Any:
        if name not in self.values:
            raise ParameterError(f"parameter '{name}' is not declared")
        return self.values[name]

    def undeclared(self, prefixes: tuple[str, ...] = ()) -> list[str]:
        """Override names nothing declared (typos in YAML), except those under dynamic ``prefixes``."""
        return sorted(n for n in self._overrides
                      if n not in self.specs and not n.startswith(prefixes) and n != "type")


def builtin_type(value: Any) -> type:
    if isinstance(value, bool):
        return bool
    for t in (int, float, str):
        if isinstance(value, t):
            return t
    if isinstance(value, (list, tuple)):
        return list
    raise ParameterError(f"unsupported parameter default {value!r}")
