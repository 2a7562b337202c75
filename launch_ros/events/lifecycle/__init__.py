"""``launch_ros.events.lifecycle``: ``ChangeState`` (what ``EmitEvent`` asks a lifecycle node to do) and
``StateTransition`` (what ``OnStateTransition`` handlers receive).

``EmitEvent(event=ChangeState(...))`` starts, for each lifecycle node the matcher picks among those resolved
before it, a helper process (``python -m launch_ros.lifecycle_change``) that waits for the node's
``change_state`` service, as launch_ros does, triggers the transition and reports it; ``OnStateTransition``
handlers react to those reports.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from launch.events import Event

__all__ = ["ChangeState", "StateTransition", "TRANSITION_LABELS"]

# lifecycle_msgs/msg/Transition's ids and ros2 lifecycle's labels for them
TRANSITION_LABELS = {1: "configure", 2: "cleanup", 3: "activate", 4: "deactivate", 5: "shutdown", 6: "shutdown",
                     7: "shutdown"}


class ChangeState(Event):
    name = "launch_ros.events.lifecycle.ChangeState"

    def __init__(self, *, lifecycle_node_matcher: Callable[[Any], bool], transition_id: int) -> None:
        if not callable(lifecycle_node_matcher):
            raise TypeError("ChangeState: 'lifecycle_node_matcher' must be callable (launch_ros.events.matches_action)")
        if transition_id not in TRANSITION_LABELS:
            raise ValueError(f"ChangeState: transition_id {transition_id!r} is not one of lifecycle_msgs' "
                             f"Transition.TRANSITION_* ids {sorted(TRANSITION_LABELS)}")
        self.lifecycle_node_matcher = lifecycle_node_matcher
        self.transition_id = transition_id

    def emit(self, resolver: Any, scope: Any, source: Any) -> None:
        """What ``EmitEvent`` does with this event: a helper process per matching lifecycle node."""
        from launch_ros.actions import LifecycleChangeProcess, LifecycleNode

        targets = [(node, fqn) for node in resolver.lifecycle_nodes for fqn in node.fully_qualified_names
                   if self.lifecycle_node_matcher(node)]
        if not targets:
            resolver.log(f"{source}: ChangeState({TRANSITION_LABELS[self.transition_id]}) matched no "
                         f"{LifecycleNode.__name__} resolved before it; ignored", level="WARN")
        for node, fqn in targets:
            helper = LifecycleChangeProcess(node, fqn, TRANSITION_LABELS[self.transition_id])
            helper.source = source
            resolver.walk([helper], scope)


class StateTransition(Event):
    """A lifecycle node went from ``start_state`` to ``goal_state`` by ``transition`` (labels, as
    ``lifecycle_msgs/msg/TransitionEvent`` carries them)."""

    name = "launch_ros.events.lifecycle.StateTransition"

    def __init__(self, *, action: Any, node_name: str, transition: str, start_state: str, goal_state: str) -> None:
        self.action = action
        self.node_name = node_name
        self.transition = transition
        self.start_state = start_state
        self.goal_state = goal_state

    @property
    def msg(self) -> Any:
        import msgs

        state = msgs.get_type("lifecycle_msgs/msg/State")
        transition = msgs.get_type("lifecycle_msgs/msg/Transition")
        event = msgs.get_type("lifecycle_msgs/msg/TransitionEvent")
        return event(transition=transition(label=self.transition), start_state=state(label=self.start_state),
                     goal_state=state(label=self.goal_state))
