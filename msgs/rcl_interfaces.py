"""Message types of the ROS package ``rcl_interfaces`` (``from msgs.rcl_interfaces import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("rcl_interfaces/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
