"""Parameter schemas: declare a set of parameters once, as a dataclass, and read them back as a typed object.

The role generate_parameter_library plays for ros2_controllers. Each field is one parameter, its type the
annotation (``float``, ``int``, ``bool``, ``str``, ``list[str]``, ``list[float]``, ``X | None``), its default,
bounds, choices and description given with ``param(...)``. A field whose type is another schema dataclass is
a namespace (``constraints.goal_time``, declared with ``namespace(Schema)``); ``per_key(Schema, keys="joints")`` is a map with one entry per name
listed in another parameter (generate_parameter_library's ``__map_joints``): ``gains.<joint>.p``.

Values come as ROS params files give them (nested maps, or dotted names, see ``nodes.core.params``) and are
checked by the one coercion of ``nodes.core.params``; a bad value raises ``ParameterError`` naming the
dotted parameter. ``Loaded.unknown`` lists the given names no field declares (typos), for a warning.

```python
@dataclass(frozen=True)
class Gains:
    p: float = param(0.0, min_value=0.0, description="proportional gain")

@dataclass(frozen=True)
class Params:
    joints: list[str] = param([], description="controlled joints")
    gains: dict[str, Gains] = per_key(Gains, keys="joints")

loaded = load_parameters(Params, {"joints": ["a"], "gains": {"a": {"p": 2.0}}})
loaded.values.gains["a"].p  # 2.0
```
"""

from __future__ import annotations

import copy
import dataclasses
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from nodes.core.params import ParameterDescriptor, ParameterError, coerce

__all__ = ["Loaded", "ParameterError", "describe", "load_parameters", "namespace", "param", "per_key"]

T = TypeVar("T")
_PARAM = "zenroid.param"
_MAP = "zenroid.per_key"


@dataclass(frozen=True)
class _ParamOptions:
    description: str
    min_value: float | None
    max_value: float | None
    choices: tuple[Any, ...] | None
    validator: Callable[[Any], str | None] | None
    allow_infinite: bool


@dataclass(frozen=True)
class _MapOptions:
    schema: type
    keys: tuple[str, ...]   # top-level list parameters naming the entries; the first non-empty one counts
    inline: bool            # entries directly under the parent namespace (``constraints.<joint>.goal``)
    description: str


def param(default: Any, *, description: str = "", min_value: float | None = None, max_value: float | None = None,
          choices: tuple[Any, ...] | list[Any] | None = None, validator: Callable[[Any], str | None] | None = None,
          allow_infinite: bool = False) -> Any:
    """One parameter field. ``allow_infinite``: ``.inf`` is a valid value (a clamp meaning "none")."""
    options = _ParamOptions(description, min_value, max_value, tuple(choices) if choices is not None else None,
                            validator, allow_infinite)
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata={_PARAM: options})
    return dataclasses.field(default=default, metadata={_PARAM: options})


def namespace(schema: type) -> Any:
    """A group of parameters under the field's name (``constraints.goal_time``), itself a schema dataclass."""
    return dataclasses.field(default_factory=schema)


def per_key(schema: type, *, keys: str | tuple[str, ...], inline: bool = False, description: str = "") -> Any:
    """A map ``name -> schema`` with one entry per name of the list parameter ``keys`` (or the first non-empty
    of several). The entries' parameters are ``<field>.<name>.<param>``, or ``<name>.<param>`` in the parent
    namespace when ``inline``."""
    options = _MapOptions(schema, (keys,) if isinstance(keys, str) else tuple(keys), inline, description)
    return dataclasses.field(default_factory=dict, metadata={_MAP: options})


@dataclass
class Loaded(typing.Generic[T]):
    values: T
    unknown: list[str]   # given names no field declares (typos in YAML), sorted


def load_parameters(schema: type[T], given: Mapping[str, Any], *, ignore: tuple[str, ...] = ()) -> Loaded[T]:
    """The typed parameters of ``schema`` from ``given`` (nested or dotted names; later dotted names win).
    Names in ``ignore`` are neither loaded nor reported unknown (a controller's ``type``)."""
    flat = _flatten(given)
    used: set[str] = set()
    values = _load(schema, "", flat, used, root=None)
    unknown = sorted(n for n in flat if n not in used and n not in ignore)
    return Loaded(values, unknown)


def describe(schema: type, *, keys: Mapping[str, list[str]] | None = None) -> list[ParameterDescriptor]:
    """Every parameter of ``schema`` as a descriptor with its dotted name (per-key maps expanded for ``keys``,
    e.g. ``{"joints": ["j1"]}``; left out without them): for documentation and ``--help`` style listings."""
    found: list[ParameterDescriptor] = []
    for name, ftype, field in _fields(schema):
        if _PARAM in field.metadata:
            found.append(_descriptor(name, ftype, field))
        elif _MAP in field.metadata:
            options: _MapOptions = field.metadata[_MAP]
            for key in next((keys[k] for k in options.keys if keys and keys.get(k)), []):
                prefix = key if options.inline else f"{name}.{key}"
                found += [dataclasses.replace(d, name=f"{prefix}.{d.name}") for d in describe(options.schema)]
        elif dataclasses.is_dataclass(ftype):
            found += [dataclasses.replace(d, name=f"{name}.{d.name}") for d in describe(ftype, keys=keys)]
    return found


# ------------------------------------------------------------------------------------------------ loading
def _fields(schema: type) -> list[tuple[str, Any, dataclasses.Field]]:
    if not dataclasses.is_dataclass(schema):
        raise TypeError(f"{schema!r} is not a parameter schema (a dataclass)")
    hints = typing.get_type_hints(schema)
    return [(f.name, hints[f.name], f) for f in dataclasses.fields(schema)]


def _value_type(annotation: Any) -> tuple[type | None, type | None]:
    """(type, list item type) of an annotation: ``float``, ``list[str]``, ``float | None``, ``dict``."""
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        annotation = next(a for a in args if a is not type(None))
        args = typing.get_args(annotation)
    origin = typing.get_origin(annotation) or annotation
    if origin is list:
        return list, (args[0] if args else None)
    return origin, None


def _descriptor(name: str, annotation: Any, field: dataclasses.Field) -> ParameterDescriptor:
    options: _ParamOptions = field.metadata[_PARAM]
    ptype, item = _value_type(annotation)
    default = field.default if field.default is not dataclasses.MISSING else field.default_factory()  # type: ignore[misc]
    return ParameterDescriptor(name, default, ptype, options.description, options.min_value, options.max_value,
                               options.choices, options.validator, element_type=item,
                               allow_infinite=options.allow_infinite)


def _load(schema: type, prefix: str, flat: dict[str, Any], used: set[str], root: dict[str, Any] | None) -> Any:
    values: dict[str, Any] = {}
    fields = _fields(schema)
    top = root if root is not None else values   # per-key maps take their names from the top level
    # parameters first (a map may be keyed by one of them), then namespaces and maps
    for name, ftype, field in fields:
        if _PARAM in field.metadata:
            desc = _descriptor(prefix + name, ftype, field)
            given = flat.get(desc.name, desc.default)
            if desc.name in flat:
                used.add(desc.name)
            values[name] = coerce(desc, given)
    for name, ftype, field in fields:
        if _MAP in field.metadata:
            options: _MapOptions = field.metadata[_MAP]
            names = next((list(top[k]) for k in options.keys if top.get(k)), [])
            entry_prefix = prefix if options.inline else f"{prefix}{name}."
            values[name] = {key: _load(options.schema, f"{entry_prefix}{key}.", flat, used, top) for key in names}
        elif _PARAM not in field.metadata:
            if not dataclasses.is_dataclass(ftype):
                raise TypeError(f"{schema.__name__}.{name}: use param(...) or per_key(...), or a schema dataclass")
            values[name] = _load(ftype, f"{prefix}{name}.", flat, used, top)
    return schema(**values)


def _flatten(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"constraints": {"j1": {"goal": 0.1}}}`` -> ``{"constraints.j1.goal": 0.1}``; dotted names stay."""
    flat: dict[str, Any] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(_flatten(value, f"{name}."))   # an empty map declares nothing
        else:
            flat[name] = value
    return flat

