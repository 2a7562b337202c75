"""REP-2011 type descriptions and RIHS01 type hashes of our interface definitions.

ROS 2 (Iron and later) names every message, service and action type by a hash of its *type description*:
the type's fields (name, type id, capacities, nested type name) plus the descriptions of every type it
references, serialised as JSON and hashed with SHA-256. rmw_zenoh puts the hash in its data keys and
liveliness tokens, so a ROS 2 node only talks to ours if our definitions hash exactly like the standard
ones (tests pin them against rosbags' independent implementation).

Services are described as a type with ``request_message``, ``response_message`` and ``event_message``
fields; actions add ``send_goal_service``, ``get_result_service`` and ``feedback_message`` (the action's
``_SendGoal``, ``_GetResult`` and ``_FeedbackMessage`` parts hash as services/messages of their own).
"""

from __future__ import annotations

import functools
import hashlib
import json
from typing import Any

from msgs.idl import FieldSpec
from msgs.registry import get_spec

# type_description_interfaces/msg/FieldType
_TYPE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8,
    "uint64": 9, "float32": 10, "float64": 11, "char": 3, "bool": 15, "byte": 16, "string": 17,
    "wstring": 18, "bounded_string": 21, "bounded_wstring": 22,
}
_FIXED_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144
_EMPTY_MEMBER = FieldSpec("structure_needs_at_least_one_member", "uint8")
_EVENT_INFO = "service_msgs/msg/ServiceEventInfo"
_TIME = "builtin_interfaces/msg/Time"
_UUID = "unique_identifier_msgs/msg/UUID"

Struct = tuple[str, tuple[tuple[str, int, int, int, str], ...]]  # (type name, fields)


def _field(f: FieldSpec) -> tuple[str, int, int, int, str]:
    nested = "" if f.is_primitive else f.base
    if nested:
        tid = _TYPE_IDS["nested"]
    elif f.string_bound is not None:
        tid = _TYPE_IDS["bounded_" + f.base]
    else:
        tid = _TYPE_IDS[f.base]
    capacity = 0
    if f.is_array:
        if f.array_size is not None:
            tid, capacity = tid + _FIXED_ARRAY, f.array_size
        elif f.upper_bound is not None:
            tid, capacity = tid + _BOUNDED_SEQUENCE, f.upper_bound
        else:
            tid += _UNBOUNDED_SEQUENCE
    return (f.name, tid, capacity, f.string_bound or 0, nested)


def _nested(name: str, type_name: str, bound: int | None = None) -> FieldSpec:
    return FieldSpec(name, type_name, is_array=bound is not None, upper_bound=bound)


def _service_fields(name: str) -> dict[str, tuple[FieldSpec, ...]]:
    """The synthetic structs a service ``name`` ("pkg/srv/X" or "pkg/action/X_SendGoal") is made of."""
    return {
        name: (_nested("request_message", f"{name}_Request"), _nested("response_message", f"{name}_Response"),
               _nested("event_message", f"{name}_Event")),
        f"{name}_Event": (_nested("info", _EVENT_INFO), _nested("request", f"{name}_Request", 1),
                          _nested("response", f"{name}_Response", 1)),
    }


_SYNTHETIC: dict[str, tuple[FieldSpec, ...]] = {
    # service_msgs is not one of our packages: its one message, as Jazzy defines it (char[16] is uint8[16]).
    _EVENT_INFO: (FieldSpec("event_type", "uint8"), _nested("stamp", _TIME),
                  FieldSpec("client_gid", "char", is_array=True, array_size=16), FieldSpec("sequence_number", "int64")),
}


def _synthetic_fields(type_name: str) -> tuple[FieldSpec, ...] | None:
    """Fields of types that have no definition file: service/action compositions and service events."""
    if type_name in _SYNTHETIC:
        return _SYNTHETIC[type_name]
    pkg, kind, name = type_name.split("/")
    if kind == "srv" and "_" not in name:
        return _service_fields(type_name)[type_name]
    if name.endswith("_Event"):
        return _service_fields(type_name[: -len("_Event")])[type_name]
    if kind == "action":
        if name.endswith(("_SendGoal", "_GetResult")):
            return _service_fields(type_name)[type_name]
        if "_" not in name:
            return (_nested("goal", f"{type_name}_Goal"), _nested("result", f"{type_name}_Result"),
                    _nested("feedback", f"{type_name}_Feedback"),
                    _nested("send_goal_service", f"{type_name}_SendGoal"),
                    _nested("get_result_service", f"{type_name}_GetResult"),
                    _nested("feedback_message", f"{type_name}_FeedbackMessage"))
    return None


def _struct(type_name: str) -> Struct:
    fields = _synthetic_fields(type_name)
    if fields is None:
        fields = get_spec(type_name).fields
    return type_name, tuple(_field(f) for f in (fields or (_EMPTY_MEMBER,)))


def type_description(type_name: str) -> dict[str, Any]:
    """The REP-2011 description of ``type_name`` (without default values, as hashed)."""
    structs: dict[str, Struct] = {}
    pending = [type_name]
    while pending:
        current = pending.pop()
        if current in structs:
            continue
        structs[current] = _struct(current)
        pending.extend(nested for *_, nested in structs[current][1] if nested)

    def as_dict(struct: Struct) -> dict[str, Any]:
        name, fields = struct
        return {"type_name": name, "fields": [
            {"name": n, "type": {"type_id": t, "capacity": c, "string_capacity": s, "nested_type_name": nt}}
            for n, t, c, s, nt in fields]}

    return {"type_description": as_dict(structs[type_name]),
            "referenced_type_descriptions": [as_dict(structs[k]) for k in sorted(structs) if k != type_name]}


@functools.cache
def rihs01(type_name: str) -> str:
    """``RIHS01_<sha256 hex>`` of a message ("pkg/msg/X"), service ("pkg/srv/X") or action part
    ("pkg/action/X", "pkg/action/X_SendGoal", "pkg/action/X_GetResult", "pkg/action/X_FeedbackMessage")."""
    text = json.dumps(type_description(type_name), separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()
