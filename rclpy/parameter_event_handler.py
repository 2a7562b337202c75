"""``ParameterEventHandler``: callbacks on other nodes' parameter changes, read from ``/parameter_events``,
as rclpy's (Jazzy).

A parameter callback is called with the ``rcl_interfaces/msg/Parameter`` of each event of its node that
declares or sets (``new_parameters``, ``changed_parameters``) its parameter, an event callback with every
``rcl_interfaces/msg/ParameterEvent``; the newest callback runs first. A node name without a leading ``/``
is relative to the handler node's namespace, an empty one is the handler node itself.

One deliberate difference: a callback may add or remove callbacks (rclpy holds a lock that is not
re-entrant while it calls them, so there it deadlocks); the change applies from the next event on.
"""

from __future__ import annotations

import threading
from collections import defaultdict
from collections.abc import Callable, Iterator
from itertools import chain
from typing import Any

import msgs
from rclpy.qos import qos_profile_parameter_events

ParameterEvent = msgs.get_type("rcl_interfaces/msg/ParameterEvent")


class ParameterCallbackHandle:
    def __init__(self, parameter_name: str, node_name: str, callback: Callable[[Any], None]) -> None:
        self.parameter_name = parameter_name
        self.node_name = node_name
        self.callback = callback
        self.mutex = threading.Lock()


class ParameterEventCallbackHandle:
    def __init__(self, callback: Callable[[Any], None]) -> None:
        self.callback = callback
        self.mutex = threading.Lock()


class ParameterEventHandler:
    class Callbacks:
        """The handler's callbacks by (parameter name, fully qualified node name), and its event callbacks."""

        def __init__(self) -> None:
            self.parameter_callbacks: dict[tuple[str, str], list[ParameterCallbackHandle]] = defaultdict(list)
            self.event_callbacks: list[ParameterEventCallbackHandle] = []
            self.mutex = threading.RLock()

        def event_callback(self, event: Any) -> None:
            with self.mutex:   # a snapshot: a callback may add or remove callbacks
                parameter_callbacks = [(key, list(handles)) for key, handles in self.parameter_callbacks.items()]
                event_callbacks = list(self.event_callbacks)
            for (param_name, node_name), handles in parameter_callbacks:
                parameter = ParameterEventHandler.get_parameter_from_event(
                    event, parameter_name=param_name, node_name=node_name)
                if parameter is not None:
                    for handle in handles:
                        with handle.mutex:
                            handle.callback(parameter)
            for handle in event_callbacks:
                with handle.mutex:
                    handle.callback(event)

        def add_parameter_callback(self, parameter_name: str, node_name: str,
                                   callback: Callable[[Any], None]) -> ParameterCallbackHandle:
            handle = ParameterCallbackHandle(parameter_name=parameter_name, node_name=node_name, callback=callback)
            with self.mutex:
                self.parameter_callbacks[(parameter_name, node_name)].insert(0, handle)
            return handle

        def remove_parameter_callback(self, handle: ParameterCallbackHandle) -> None:
            with self.mutex:
                key = (handle.parameter_name, handle.node_name)
                handles = self.parameter_callbacks.get(key)
                if not handles or handle not in handles:
                    raise RuntimeError("Callback doesn't exist")
                handles.remove(handle)
                if not handles:
                    self.parameter_callbacks.pop(key)

        def add_parameter_event_callback(self, callback: Callable[[Any], None]) -> ParameterEventCallbackHandle:
            handle = ParameterEventCallbackHandle(callback=callback)
            with self.mutex:
                self.event_callbacks.insert(0, handle)
            return handle

        def remove_parameter_event_callback(self, handle: ParameterEventCallbackHandle) -> None:
            with self.mutex:
                if handle not in self.event_callbacks:
                    raise RuntimeError("Callback doesn't exist")
                self.event_callbacks.remove(handle)

    def __init__(self, node: Any, qos_profile: Any = qos_profile_parameter_events, callback_group: Any = None,
                 event_callbacks: Any = None, qos_overriding_options: Any = None, raw: bool = False) -> None:
        self.node = node
        self.qos_profile = qos_profile
        self._callbacks = ParameterEventHandler.Callbacks()
        self.parameter_event_subscription = node.create_subscription(
            ParameterEvent, "/parameter_events", self._callbacks.event_callback, self.qos_profile,
            callback_group=callback_group, event_callbacks=event_callbacks,
            qos_overriding_options=qos_overriding_options, raw=raw)

    def destroy(self) -> None:
        self.node.destroy_subscription(self.parameter_event_subscription)

    @staticmethod
    def get_parameter_from_event(event: Any, parameter_name: str, node_name: str) -> Any | None:
        """The event's rcl_interfaces/msg/Parameter named ``parameter_name`` (new or changed) when the event is
        ``node_name``'s (fully qualified), else None."""
        if event.node == node_name:
            for parameter in chain(event.new_parameters, event.changed_parameters):
                if parameter.name == parameter_name:
                    return parameter
        return None

    @staticmethod
    def get_parameters_from_event(event: Any) -> Iterator[Any]:
        """Every new and changed parameter of the event (not the deleted ones)."""
        yield from chain(event.new_parameters, event.changed_parameters)

    def add_parameter_callback(self, parameter_name: str, node_name: str,
                               callback: Callable[[Any], None]) -> ParameterCallbackHandle:
        return self._callbacks.add_parameter_callback(parameter_name=parameter_name,
                                                      node_name=self._resolve_path(node_name), callback=callback)

    def remove_parameter_callback(self, handle: ParameterCallbackHandle) -> None:
        self._callbacks.remove_parameter_callback(handle)

    def add_parameter_event_callback(self, callback: Callable[[Any], None]) -> ParameterEventCallbackHandle:
        return self._callbacks.add_parameter_event_callback(callback)

    def remove_parameter_event_callback(self, handle: ParameterEventCallbackHandle) -> None:
        self._callbacks.remove_parameter_event_callback(handle)

    def _resolve_path(self, node_path: str | None = None) -> str:
        """The fully qualified name of ``node_path``: absolute as it is, relative to the handler node's
        namespace, empty for the handler node itself."""
        if not node_path:
            return self.node.get_fully_qualified_name()
        if node_path.startswith("/"):
            return node_path
        resolved = "/".join([self.node.get_namespace().lstrip("/"), node_path])
        return resolved if resolved.startswith("/") else f"/{resolved}"

