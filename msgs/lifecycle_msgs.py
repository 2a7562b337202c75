"""Message types of the ROS package ``lifecycle_msgs`` (``from msgs.lifecycle_msgs import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("lifecycle_msgs/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
