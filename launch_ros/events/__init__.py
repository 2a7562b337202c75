"""``launch_ros.events``: which launch actions an event is meant for (``matches_action``, ``matches_node_name``),
and the lifecycle events (``launch_ros.events.lifecycle``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["matches_action", "matches_node_name"]


def matches_action(target_action: Any) -> Callable[[Any], bool]:
    """A matcher for one action object (``ChangeState(lifecycle_node_matcher=matches_action(node))``)."""
    return lambda action: action is target_action


def matches_node_name(node_name: str) -> Callable[[Any], bool]:
    """A matcher for the node whose fully qualified name is ``node_name`` (``/ns/name``)."""
    wanted = "/" + node_name.strip("/")
    return lambda action: wanted in getattr(action, "fully_qualified_names", [])
