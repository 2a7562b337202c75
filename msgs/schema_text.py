"""Full ROS 2 message definitions (a type plus every nested type) as ``ros2msg`` schema text.

This is what MCAP files, Foxglove and ``ros2 bag`` expect: the type's fields, then each dependency
after a line of ``=`` and ``MSG: pkg/Type``.
"""

from __future__ import annotations

from msgs.idl import FieldSpec
from msgs.registry import get_spec

_SEPARATOR = "=" * 80


def ros_name(type_name: str) -> str:
    """"pkg/msg/Name" → "pkg/Name": how definitions refer to nested types (action/srv parts too)."""
    parts = type_name.split("/")
    return f"{parts[0]}/{parts[2]}" if len(parts) == 3 else type_name


def _field_line(f: FieldSpec) -> str:
    base = f.base if f.is_primitive else ros_name(f.base)
    if f.string_bound is not None:
        base += f"<={f.string_bound}"
    if f.is_array:
        base += f"[{f.array_size}]" if f.array_size is not None else (
            f"[<={f.upper_bound}]" if f.upper_bound is not None else "[]")
    return f"{base} {f.name}"


def _body(type_name: str) -> str:
    spec = get_spec(type_name)
    lines = []
    for name, value in spec.constants.items():
        lines.append(f"{_constant_type(spec.text, name) or 'int32'} {name}={_literal(value)}")
    lines += [_field_line(f) for f in spec.fields]
    return "\n".join(lines)


def _constant_type(text: str, name: str) -> str | None:
    for line in text.splitlines():
        code = line.split("#", 1)[0].strip()
        parts = code.split(None, 1)
        if len(parts) == 2 and "=" in parts[1] and parts[1].split("=", 1)[0].strip() == name:
            return parts[0]
    return None


def _literal(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace('"', '\\"') + '"'
    return repr(value)


def full_definition(type_name: str) -> str:
    """The schema text of ``type_name`` with all nested types, dependencies in first-use order."""
    order: list[str] = []
    seen = {type_name}
    stack = [type_name]
    while stack:
        current = stack.pop(0)
        for f in get_spec(current).fields:
            if not f.is_primitive and f.base not in seen:
                seen.add(f.base)
                order.append(f.base)
                stack.append(f.base)
    parts = [_body(type_name)]
    for dep in order:
        parts.append(f"{_SEPARATOR}\nMSG: {ros_name(dep)}\n{_body(dep)}")
    return "\n".join(parts) + "\n"
