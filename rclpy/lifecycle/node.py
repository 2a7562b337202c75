"""``rclpy.lifecycle.LifecycleNode``: rclpy's managed node on a ``nodes.core.lifecycle.LifecycleNode``.

The core node owns the state machine and the ``~/get_state`` / ``~/change_state`` services; each transition
calls the rclpy face's ``on_configure(state)`` & co. and maps ``TransitionCallbackReturn``: SUCCESS moves on,
FAILURE stays, ERROR runs ``on_error`` (SUCCESS: unconfigured, else finalized).
"""

from __future__ import annotations

import enum
from typing import Any

import msgs
from nodes.core import lifecycle as core_lifecycle
from rclpy._entities import Publisher
from rclpy.node import Node

PRIMARY = {0: "unknown", 1: "unconfigured", 2: "inactive", 3: "active", 4: "finalized"}


class TransitionCallbackReturn(enum.IntEnum):
    SUCCESS = 97
    FAILURE = 98
    ERROR = 99


class LifecycleState:
    def __init__(self, state_id: int, label: str) -> None:
        self.state_id, self.label = state_id, label

    def __repr__(self) -> str:
        return f"LifecycleState(state_id={self.state_id}, label={self.label!r})"


State = LifecycleState


class ManagedEntity:
    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS


class SimpleManagedEntity(ManagedEntity):
    def __init__(self) -> None:
        self._enabled = False

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._enabled = True
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._enabled = False
        return TransitionCallbackReturn.SUCCESS

    @property
    def is_activated(self) -> bool:
        return self._enabled


class LifecyclePublisher(SimpleManagedEntity, Publisher):
    """Publishes only while activated; a message published while inactive is dropped with a warning."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        SimpleManagedEntity.__init__(self)
        Publisher.__init__(self, *args, **kwargs)

    def publish(self, msg: Any) -> None:
        if not self._enabled:
            self._node.get_logger().warn(
                f"Trying to publish on the topic '{self.topic_name}', but the publisher is not activated",
                once=True)
            return
        super().publish(msg)


class _LifecycleCore(core_lifecycle.LifecycleNode):
    """The core managed node under an rclpy lifecycle node: callbacks on the spinning thread, hooks that ask
    the face."""

    callbacks_on_spin_thread = True
    face: Any = None

    def _ask(self, hook: str) -> bool:
        face = self.face
        if face is None:
            return True
        return face._zr_transition(hook, self)

    def on_configure(self) -> bool:
        return self._ask("on_configure")

    def on_activate(self) -> bool:
        return self._ask("on_activate")

    def on_deactivate(self) -> bool:
        return self._ask("on_deactivate")

    def on_cleanup(self) -> bool:
        return self._ask("on_cleanup")

    def on_shutdown(self) -> bool:
        return self._ask("on_shutdown")


class LifecycleNodeMixin:
    """The lifecycle half of ``LifecycleNode`` (rclpy's mixin); the node half is ``rclpy.node.Node``."""

    def _zr_lifecycle_init(self, enable_communication_interface: bool = True) -> None:
        self._zr.face = self
        self._managed_entities: set[ManagedEntity] = set()
        self._zr_transition_pub = None
        try:
            event_type = msgs.get_type("lifecycle_msgs/msg/TransitionEvent")
        except Exception:  # noqa: BLE001 - older definitions: no transition events
            event_type = None
        if event_type is not None and enable_communication_interface:
            self._zr_transition_pub = self._zr.create_publisher(event_type, "~/transition_event")
        self._zr_serve_extra()

    def _zr_serve_extra(self) -> None:
        """``~/get_available_states`` and ``~/get_available_transitions`` when lifecycle_msgs has them."""
        try:
            states_srv = msgs.get_type("lifecycle_msgs/srv/GetAvailableStates")
            transitions_srv = msgs.get_type("lifecycle_msgs/srv/GetAvailableTransitions")
            state_msg = msgs.get_type("lifecycle_msgs/msg/State")
            description = msgs.get_type("lifecycle_msgs/msg/TransitionDescription")
            transition = msgs.get_type("lifecycle_msgs/msg/Transition")
        except Exception:  # noqa: BLE001
            return

        def states(request: Any) -> Any:
            return states_srv.Response(available_states=[state_msg(id=i, label=label) for i, label in PRIMARY.items()])

        def transitions(request: Any) -> Any:
            out = []
            for tid, (label, sources, _, target) in core_lifecycle.TRANSITIONS.items():
                if self._zr.state in sources:
                    out.append(description(
                        transition=transition(id=tid, label=label),
                        start_state=state_msg(id=self._zr.state, label=PRIMARY[self._zr.state]),
                        goal_state=state_msg(id=target, label=PRIMARY[target])))
            return transitions_srv.Response(available_transitions=out)

        self._zr.create_service(states_srv, "~/get_available_states", states)
        self._zr.create_service(transitions_srv, "~/get_available_transitions", transitions)

    def _zr_transition(self, hook: str, core: Any) -> bool:
        previous = LifecycleState(core.state, PRIMARY.get(core.state, "unknown"))
        try:
            verdict = getattr(self, hook)(previous)
        except Exception as exc:  # noqa: BLE001 - an exception in a transition is its ERROR
            self.get_logger().error(f"{hook} raised {type(exc).__name__}: {exc}")
            verdict = TransitionCallbackReturn.ERROR
        if verdict == TransitionCallbackReturn.SUCCESS:
            self._zr_publish_event(core.state, hook)
            return True
        if verdict == TransitionCallbackReturn.ERROR:
            try:
                recovered = self.on_error(previous) == TransitionCallbackReturn.SUCCESS
            except Exception:  # noqa: BLE001
                recovered = False
            core.state = core_lifecycle.UNCONFIGURED if recovered else core_lifecycle.FINALIZED
        return False

    def _zr_publish_event(self, start: int, hook: str) -> None:
        pub = self._zr_transition_pub
        if pub is None:
            return
        goal = {"on_configure": 2, "on_activate": 3, "on_deactivate": 2, "on_cleanup": 1, "on_shutdown": 4}[hook]
        state = msgs.get_type("lifecycle_msgs/msg/State")
        pub.publish(pub.msg_type(start_state=state(id=start, label=PRIMARY[start]),
                                 goal_state=state(id=goal, label=PRIMARY[goal])))

    # the callbacks (override them); the defaults succeed, activating and deactivating managed entities
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        for entity in list(self._managed_entities):
            entity.on_activate(state)
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        for entity in list(self._managed_entities):
            entity.on_deactivate(state)
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.SUCCESS

    def add_managed_entity(self, entity: ManagedEntity) -> None:
        self._managed_entities.add(entity)

    def create_lifecycle_publisher(self, msg_type: Any, topic: str, qos_profile: Any, **kwargs: Any
                                   ) -> LifecyclePublisher:
        publisher = self.create_publisher(msg_type, topic, qos_profile, publisher_class=LifecyclePublisher,
                                          **kwargs)
        self.add_managed_entity(publisher)
        return publisher

    def destroy_lifecycle_publisher(self, publisher: LifecyclePublisher) -> bool:
        self._managed_entities.discard(publisher)
        return self.destroy_publisher(publisher)

    def _zr_trigger(self, label: str) -> TransitionCallbackReturn:
        before = self._zr.state
        ok = self._zr.trigger(label)
        if ok:
            return TransitionCallbackReturn.SUCCESS
        if self._zr.state != before:
            return TransitionCallbackReturn.ERROR
        return TransitionCallbackReturn.FAILURE

    def trigger_configure(self) -> TransitionCallbackReturn:
        return self._zr_trigger("configure")

    def trigger_cleanup(self) -> TransitionCallbackReturn:
        return self._zr_trigger("cleanup")

    def trigger_activate(self) -> TransitionCallbackReturn:
        return self._zr_trigger("activate")

    def trigger_deactivate(self) -> TransitionCallbackReturn:
        return self._zr_trigger("deactivate")

    def trigger_shutdown(self) -> TransitionCallbackReturn:
        return self._zr_trigger("shutdown")

    @property
    def _state_machine(self) -> Any:
        return LifecycleState(self._zr.state, PRIMARY.get(self._zr.state, "unknown"))


class LifecycleNode(LifecycleNodeMixin, Node):
    _zr_core_class = _LifecycleCore

    def __init__(self, node_name: str, *args: Any, enable_communication_interface: bool = True,
                 **kwargs: Any) -> None:
        Node.__init__(self, node_name, *args, **kwargs)
        self._zr_lifecycle_init(enable_communication_interface)
