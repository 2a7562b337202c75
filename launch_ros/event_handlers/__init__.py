"""``launch_ros.event_handlers``: ``OnStateTransition``, a reaction to a lifecycle node's transition."""

from __future__ import annotations

import re
from typing import Any

from launch.actions import run_callable_or_actions
from launch.event_handlers import EventHandler

__all__ = ["OnStateTransition"]

# the line launch_ros.lifecycle_change prints once a transition is done
REPORT = re.compile(r"^lifecycle transition: (\S+) (\S+) (\S+) -> (\S+)$")


class OnStateTransition(EventHandler):
    """``entities`` when a transition of ``target_lifecycle_node`` (any lifecycle node when None) matches the
    labels given (``transition``, ``start_state``, ``goal_state``: ``'configure'``, ``'inactive'`` ...)."""

    kind = "io"

    def __init__(self, *, entities: Any, target_lifecycle_node: Any = None, transition: str | None = None,
                 start_state: str | None = None, goal_state: str | None = None, matcher: Any = None,
                 handle_once: bool = False, **kwargs: Any) -> None:
        super().__init__(handler=entities, **kwargs)
        self.target_action = self.matches   # not None: only the lifecycle helpers' lines are looked at
        self.target_lifecycle_node = target_lifecycle_node
        self.node_matcher = matcher
        self.wanted = {"transition": transition, "start_state": start_state, "goal_state": goal_state}
        self.handle_once = handle_once
        self.handled = False

    def matches(self, action: Any) -> bool:
        from launch_ros.actions import LifecycleChangeProcess

        if not isinstance(action, LifecycleChangeProcess):
            return False
        if self.target_lifecycle_node is not None and action.node is not self.target_lifecycle_node:
            return False
        return self.node_matcher is None or bool(self.node_matcher(action.node))

    def actions_for(self, event: Any, context: Any) -> list[Any]:
        from launch_ros.events.lifecycle import StateTransition

        found = REPORT.match(event.text.decode("utf-8", errors="replace").strip())
        if found is None or (self.handle_once and self.handled):
            return []
        node_name, transition, start, goal = found.groups()
        seen = {"transition": transition, "start_state": start, "goal_state": goal}
        if any(want is not None and want != seen[key] for key, want in self.wanted.items()):
            return []
        self.handled = True
        transition_event = StateTransition(action=event.action.node, node_name=node_name, transition=transition,
                                           start_state=start, goal_state=goal)
        return run_callable_or_actions(self.handler, transition_event, context)
