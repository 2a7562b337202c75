"""Message types of the ROS package ``std_srvs`` (``from msgs.std_srvs import Name``)."""

from typing import Any

from msgs.registry import get_type


def __getattr__(name: str) -> Any:
    if name.startswith("_"):
        raise AttributeError(name)
    try:
        return get_type("std_srvs/" + name)
    except KeyError as exc:
        raise AttributeError(str(exc)) from None
