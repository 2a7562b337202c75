"""Message types of the ROS package ``controller_manager_msgs`` (``from msgs.controller_manager_msgs import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("controller_manager_msgs/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
