"""Parser for ROS 2 interface definitions (``.msg``, ``.srv``, ``.action``) into field specs."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any

import yaml

# ROS primitive type -> (python type, integer range or None)
INT_RANGES: dict[str, tuple[int, int]] = {
    "int8": (-(2**7), 2**7 - 1), "uint8": (0, 2**8 - 1), "byte": (0, 2**8 - 1), "char": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1),
}
FLOAT_TYPES = frozenset({"float32", "float64"})
STRING_TYPES = frozenset({"string", "wstring"})
PRIMITIVES = frozenset({"bool", *INT_RANGES, *FLOAT_TYPES, *STRING_TYPES})
# ROS 1 style aliases still seen in tutorials
ALIASES = {"time": "builtin_interfaces/msg/Time", "duration": "builtin_interfaces/msg/Duration",
           "Header": "std_msgs/msg/Header"}

_NAME_RE = re.compile(r"^[a-zA-Z][a-zA-Z0-9_]*$")
_TYPE_RE = re.compile(
    r"^(?P<base>[a-zA-Z][a-zA-Z0-9_/]*)(?:<=(?P<strbound>\d+))?"
    r"(?P<array>\[(?P<bound><=)?(?P<size>\d*)\])?$"
)


class DefinitionError(ValueError):
    """A malformed interface definition; the message names the file (type) and line."""


@dataclass(frozen=True)
class FieldSpec:
    name: str
    base: str  # a primitive name, or a full type name "pkg/msg/Type"
    is_array: bool = False
    array_size: int | None = None  # fixed-size array T[N]
    upper_bound: int | None = None  # bounded sequence T[<=N]
    string_bound: int | None = None
    default: Any = None  # None: the ROS default for the type

    @property
    def is_primitive(self) -> bool:
        return self.base in PRIMITIVES

    @property
    def is_bytes(self) -> bool:
        """``uint8[]``/``byte[]`` travel as msgpack bin (Python ``bytes``)."""
        return self.is_array and self.base in ("uint8", "byte")


@dataclass(frozen=True)
class MsgSpec:
    type_name: str  # "pkg/msg/Name"
    fields: tuple[FieldSpec, ...]
    constants: dict[str, Any] = field(default_factory=dict)
    text: str = ""


def resolve_type(base: str, package: str) -> str:
    """Full name of a field's type as written in a definition of ``package``."""
    if base in PRIMITIVES:
        return base
    if base in ALIASES:
        return ALIASES[base]
    parts = base.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{base}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3:
        return base
    raise DefinitionError(f"bad type name '{base}'")


def _parse_value(raw: str, base: str, is_array: bool, where: str) -> Any:
    raw = raw.strip()
    try:
        if base in STRING_TYPES and not is_array:
            if len(raw) >= 2 and raw[0] == raw[-1] and raw[0] in "'\"":
                return json.loads(raw) if raw[0] == '"' else raw[1:-1]
            return raw
        value = yaml.safe_load(raw)
    except (yaml.YAMLError, json.JSONDecodeError) as exc:
        raise DefinitionError(f"{where}: bad value {raw!r}: {exc}") from None
    items = value if is_array else [value]
    if is_array and not isinstance(value, list):
        raise DefinitionError(f"{where}: array default must be a list, got {raw!r}")
    converted = []
    for item in items:
        if base == "bool":
            if not isinstance(item, bool):
                raise DefinitionError(f"{where}: {item!r} is not a bool")
        elif base in FLOAT_TYPES:
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                raise DefinitionError(f"{where}: {item!r} is not a number")
            item = float(item)
        elif base in INT_RANGES:
            if isinstance(item, bool) or not isinstance(item, int):
                raise DefinitionError(f"{where}: {item!r} is not an integer")
        elif base in STRING_TYPES:
            item = str(item)
        converted.append(item)
    return converted if is_array else converted[0]


def parse_message(text: str, type_name: str) -> MsgSpec:
    """Parse one message section. ``type_name`` is "pkg/kind/Name" (used for errors and relative types)."""
    package = type_name.split("/")[0]
    fields: list[FieldSpec] = []
    constants: dict[str, Any] = {}
    seen: set[str] = set()
    for lineno, line in enumerate(text.splitlines(), 1):
        code = line.split("#", 1)[0].strip() if '"' not in line and "'" not in line else _strip_comment(line)
        if not code:
            continue
        where = f"{type_name} line {lineno}"
        parts = code.split(None, 1)
        if len(parts) < 2:
            raise DefinitionError(f"{where}: expected '<type> <name>', got {code!r}")
        type_str, rest = parts
        m = _TYPE_RE.match(type_str)
        if not m:
            raise DefinitionError(f"{where}: bad type {type_str!r}")
        base = resolve_type(m.group("base"), package)
        is_array = m.group("array") is not None
        size_text = m.group("size")
        array_size = upper_bound = None
        if is_array and size_text:
            if m.group("bound"):
                upper_bound = int(size_text)
            else:
                array_size = int(size_text)
        string_bound = int(m.group("strbound")) if m.group("strbound") else None
        if "=" in rest and _NAME_RE.match(rest.split("=", 1)[0].strip() or "-"):
            name, raw_value = (s.strip() for s in rest.split("=", 1))
            if base not in PRIMITIVES or is_array:
                raise DefinitionError(f"{where}: constant {name} must be a primitive")
            constants[name] = _parse_value(raw_value, base, False, where)
            continue
        name_parts = rest.split(None, 1)
        name = name_parts[0]
        if not _NAME_RE.match(name):
            raise DefinitionError(f"{where}: bad field name {name!r}")
        if name in seen:
            raise DefinitionError(f"{where}: duplicate field {name!r}")
        seen.add(name)
        default = None
        if len(name_parts) > 1:
            if base not in PRIMITIVES:
                raise DefinitionError(f"{where}: only primitive fields take defaults")
            default = _parse_value(name_parts[1], base, is_array, where)
        fields.append(FieldSpec(name, base, is_array, array_size, upper_bound, string_bound, default))
    return MsgSpec(type_name, tuple(fields), constants, text)


def _strip_comment(line: str) -> str:
    """Drop a trailing comment while keeping '#' inside quoted string values."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#":
            return line[:i].strip()
    return line.strip()


def split_sections(text: str, count: int, type_name: str) -> list[str]:
    """Split a ``.srv`` (2 sections) or ``.action`` (3 sections) at its ``---`` lines."""
    sections: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            sections.append([])
        else:
            sections[-1].append(line)
    if len(sections) != count:
        raise DefinitionError(f"{type_name}: expected {count} sections separated by '---', found {len(sections)}")
    return ["\n".join(s) for s in sections]


# Cross-field rules ROS messages carry in their comments; checked after field decoding.
EQUAL_LENGTH_RULES: dict[str, tuple[str, tuple[str, ...], bool]] = {
    # type: (reference field, fields that must match it, empty allowed)
    "sensor_msgs/msg/JointState": ("name", ("position", "velocity", "effort"), True),
    "zenroid_msgs/msg/HardwareState": ("name", ("position", "velocity", "effort"), False),
    "zenroid_msgs/msg/HardwareCommand": ("name", ("interface", "value"), False),
    "gazebo_msgs/msg/ModelStates": ("name", ("pose", "twist"), False),
    "humanoid_msgs/msg/HumanoidState": ("joint_names", ("joint_positions", "joint_velocities", "joint_efforts"), True),
}
