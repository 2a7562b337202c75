"""``launch_ros.parameter_descriptions``: a parameter file, and a value with its type."""

from __future__ import annotations

from typing import Any

from launch.context import normalize

__all__ = ["Parameter", "ParameterFile", "ParameterValue"]


class ParameterFile:
    def __init__(self, param_file: Any, *, allow_substs: Any = False) -> None:
        self.param_file = normalize(param_file)
        self.allow_substs = allow_substs


class ParameterValue:
    """``value`` (a substitution, a list of them, or a plain value) read as ``value_type`` (str keeps text)."""

    def __init__(self, value: Any, *, value_type: Any = None) -> None:
        self.value = value
        self.value_type = value_type


class Parameter:
    def __init__(self, name: Any, value: Any, *, value_type: Any = None) -> None:
        self.name = normalize(name)
        self.value = ParameterValue(value, value_type=value_type)
