"""Message types of the ROS package ``builtin_interfaces`` (``from msgs.builtin_interfaces import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("builtin_interfaces/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
