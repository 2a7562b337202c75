"""ROS 2 compatible messages for zenroid: definitions as text, typed classes, msgpack codec.

>>> from msgs import get_type, encode, decode
>>> JointState = get_type("sensor_msgs/msg/JointState")
>>> decode(JointState, encode(JointState(name=["knee"], position=[0.4]))).position
[0.4]
"""

from __future__ import annotations

from typing import Any

import _zenroid_interfaces
from msgs import packages
from msgs.codec import DEFAULT_LIMITS, DecodeError, EncodeError, Limits, decode, encode, from_dict, to_dict
from msgs.compiled import builder, packer
from msgs.idl import DefinitionError
from msgs.registry import (
    Action,
    Service,
    add_search_path,
    get_class,
    get_type,
    list_types,
    package_names,
    register_message,
)
from msgs.timeutil import duration_from_sec, duration_to_sec, time_from_sec, time_map, time_to_sec

packages.install()  # ``from msgs.sensor_msgs import JointState`` (msgs/packages.py)
_zenroid_interfaces.install()  # ``from sensor_msgs.msg import JointState`` (also installed at start-up by a .pth)

__all__ = [
    "Action", "DEFAULT_LIMITS", "DecodeError", "DefinitionError", "EncodeError", "Limits", "Service", "add_search_path",
    "builder", "decode", "duration_from_sec", "duration_to_sec", "encode", "from_dict", "get_class", "get_type",
    "list_types", "package_names", "packer", "register_message", "time_from_sec", "time_map", "time_to_sec",
    "to_dict",
]


def __getattr__(name: str) -> Any:
    """``msgs.JointState``: a message class by its bare name when exactly one package defines it;
    ``msgs.sensor_msgs``: the module of a message package."""
    if name.startswith("_"):
        raise AttributeError(name)
    if name in package_names():
        import importlib

        return importlib.import_module(f"{__name__}.{name}")
    matches = [t for t in list_types() if t.rsplit("/", 1)[-1] == name]
    if len(matches) == 1:
        return get_type(matches[0])
    if not matches:
        raise AttributeError(f"module 'msgs' has no attribute or message type '{name}'")
    raise AttributeError(f"'{name}' is ambiguous: {', '.join(matches)}; use msgs.get_type()")
