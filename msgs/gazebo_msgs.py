"""Message types of the ROS package ``gazebo_msgs`` (``from msgs.gazebo_msgs import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("gazebo_msgs/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
