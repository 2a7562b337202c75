"""Typed, validated node parameters (ros2 ``declare_parameter`` with descriptors)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml


class ParameterError(ValueError):
    """A parameter value that does not satisfy its declaration; names the parameter."""


@dataclass
class ParameterDescriptor:
    name: str
    default: Any
    type: type | None
    description: str = ""
    min_value: float | None = None
    max_value: float | None = None
    choices: tuple[Any, ...] | None = None  # for a list: every item must be one of them
    validator: Callable[[Any], str | None] | None = None
    read_only: bool | str = False  # a string says why (shown when a change is refused)
    element_type: type | None = None  # a list's items (None: as the default's first item)
    allow_infinite: bool = False  # ``.inf`` accepted (a clamp or limit meaning "none"); NaN never is


def type_of_default(value: Any) -> type:
    """The parameter type a default implies (a tuple is a list; anything else unchecked)."""
    return {bool: bool, int: int, float: float, str: str, list: list, tuple: list, dict: dict}.get(type(value), object)


MAX_YAML_DEPTH = 32   # nested lists/maps in a value that came over the wire


class UntrustedYamlError(yaml.YAMLError):
    """YAML from a request that we refuse to build: aliases (self-reference, "billion laughs") or deep nesting."""


def load_untrusted_yaml(text: str, max_depth: int = MAX_YAML_DEPTH) -> Any:
    """``yaml.safe_load`` for text a request carries: no anchors/aliases (a ``&a [*a]`` value is a cycle that
    breaks whatever walks it, and aliases multiply a small text into a huge document), at most ``max_depth``
    nested collections (PyYAML builds them recursively). Raises ``yaml.YAMLError``."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
                raise UntrustedYamlError("YAML anchors and aliases (&name, *name) are not accepted here")
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > max_depth:
                    raise UntrustedYamlError(f"YAML nested deeper than {max_depth} levels")
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
        return yaml.safe_load(text)
    except RecursionError:
        raise UntrustedYamlError("YAML nested too deeply") from None


def parse_value(text: str) -> Any:
    """A command-line or ``set_parameters`` value: YAML scalars/lists (``1``, ``true``, ``[a, b]``), else the
    string (also when the YAML uses aliases or nests deeper than MAX_YAML_DEPTH)."""
    try:
        return load_untrusted_yaml(text)
    except yaml.YAMLError:
        return text


def dump_value(value: Any) -> str:
    """A parameter value as one line of YAML that ``parse_value`` reads back (no ``...`` end marker)."""
    text = yaml.safe_dump(value, default_flow_style=True, width=1 << 30).strip()
    if text.endswith("\n..."):
        text = text[: -len("\n...")].rstrip()
    elif text == "...":  # None
        text = "null"
    return text


def load_params_file(path: str | Path, node_name: str, namespace: str = "") -> dict[str, Any]:
    """Parameters for ``node_name`` from a ROS params file (``node: ros__parameters:``, ``/**``) or a flat map."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except OSError as exc:
        raise ParameterError(f"params file {p}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise ParameterError(f"params file {p}: invalid YAML: {exc}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ParameterError(f"params file {p}: expected a map at the top level")
    fq = "/" + "/".join(x for x in (namespace.strip("/"), node_name) if x)
    keys = ("/**", "**", node_name, fq, fq.lstrip("/"))
    if not any(isinstance(v, dict) and "ros__parameters" in v for v in data.values()):
        return _flatten(data)  # a flat map of parameters
    merged: dict[str, Any] = {}
    for key in keys:
        section = data.get(key)
        if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            merged.update(_flatten(section["ros__parameters"]))
    return merged


def _flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested maps become dotted names, as ROS does (``constraints.goal_time``)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(_flatten(v, name + "."))
        out[name] = v
    return out


def coerce(desc: ParameterDescriptor, value: Any) -> Any:
    """Check ``value`` against ``desc``; returns the (possibly converted) value or raises ParameterError.

    The one coercion for node and controller parameters: an int is accepted for a float, a tuple for a
    list; a bool is never a number; NaN is refused, infinity only where ``allow_infinite`` says so."""
    name = desc.name
    t = desc.type
    if t is not None and t is not object and value is not None:
        if t is list:
            if isinstance(value, tuple):
                value = list(value)
            if not isinstance(value, list):
                raise ParameterError(f"parameter '{name}': expected a list, got {type(value).__name__} {value!r}")
            item_t = desc.element_type or _item_type(desc.default)
            if item_t is not None:
                value = [_coerce_item(desc, i, item_t, x) for i, x in enumerate(value)]
        elif t is bool and not isinstance(value, bool):
            raise ParameterError(f"parameter '{name}': expected a bool, got {value!r}")
        else:
            value = _coerce_scalar(name, t, value)
    _check_number(desc, name, value)
    if desc.min_value is not None and _is_number(value) and value < desc.min_value:
        raise ParameterError(f"parameter '{name}': {value} is below the minimum {desc.min_value}")
    if desc.max_value is not None and _is_number(value) and value > desc.max_value:
        raise ParameterError(f"parameter '{name}': {value} is above the maximum {desc.max_value}")
    if desc.choices is not None and value is not None:
        for item in value if isinstance(value, list) else [value]:
            if item not in desc.choices:
                raise ParameterError(f"parameter '{name}': {item!r} is not one of {list(desc.choices)}")
    if desc.validator is not None:
        problem = desc.validator(value)
        if problem:
            raise ParameterError(f"parameter '{name}': {problem}")
    return value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _coerce_scalar(name: str, t: type, value: Any) -> Any:
    if t is float and _is_number(value):
        return float(value)
    if not isinstance(value, t) or (t in (int, float) and isinstance(value, bool)):
        raise ParameterError(f"parameter '{name}': expected {t.__name__}, got {type(value).__name__} {value!r}")
    return value


def _check_number(desc: ParameterDescriptor, name: str, value: Any) -> None:
    if isinstance(value, float) and not math.isfinite(value) and (math.isnan(value) or not desc.allow_infinite):
        raise ParameterError(f"parameter '{name}': must be finite, got {value}")


def _item_type(default: Any) -> type | None:
    if isinstance(default, list) and default:
        first = default[0]
        return float if isinstance(first, float) else type(first)
    return None


def _coerce_item(desc: ParameterDescriptor, i: int, t: type, x: Any) -> Any:
    name = f"{desc.name}[{i}]"
    if t is bool:
        if not isinstance(x, bool):
            raise ParameterError(f"parameter '{name}': expected a bool, got {x!r}")
        return x
    x = _coerce_scalar(name, t, x)
    _check_number(desc, name, x)
    return x
