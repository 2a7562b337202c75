"""Endpoint creation for a node: each ``create_*`` resolves the name, builds the endpoint on the node's
runtime and keeps it, so the node can close one (``destroy``) or all of them (``destroy_all``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import zenoh

from nodes.core.action import ActionClient, ActionServer
from nodes.core.delivery import Decoded, Delivery
from nodes.core.endpoints import Client, Publisher, Ros2Client, ServiceServer, Subscription
from nodes.core.latched import LatchedPublisher, fetch_latched, fetch_latched_history
from nodes.core.runtime import NodeRuntime


class EndpointFactory:
    def __init__(self, runtime: NodeRuntime, resolve: Callable[..., str]) -> None:
        self._runtime = runtime
        self._resolve = resolve      # Node.resolve: namespace, ``~`` and remaps
        self._entities: list[Any] = []

    def _keep(self, entity: Any) -> Any:
        self._entities.append(entity)
        return entity

    def publisher(self, msg_type: Any, topic: str, *, reliable: bool = True,
                  priority: zenoh.Priority | None = None, express: bool = False, latched: bool = False,
                  depth: int = 1, lifespan: float | None = None, ros2_qos: Any = None) -> Any:
        if latched:
            return self._keep(LatchedPublisher(self._runtime, msg_type, self._resolve(topic), depth=depth,
                                               lifespan=lifespan, ros2_qos=ros2_qos))
        return self._keep(Publisher(self._runtime, msg_type, self._resolve(topic), reliable=reliable,
                                    priority=priority, express=express, ros2_qos=ros2_qos))

    def fetch_latched(self, msg_type: Any, topic: str, timeout: float) -> Any | None:
        return fetch_latched(self._runtime.session, msg_type, self._resolve(topic), timeout)

    def fetch_latched_history(self, msg_type: Any, topic: str, timeout: float) -> list[Any]:
        return fetch_latched_history(self._runtime.session, msg_type, self._resolve(topic), timeout)

    def subscription(self, msg_type: Any, topic: str, callback: Callable[..., None], *,
                     delivery: Delivery | None = None, message: Decoded | None = None,
                     ros2_qos: Any = None) -> Subscription:
        return self._keep(Subscription(self._runtime, msg_type, self._resolve(topic, wildcards=True), callback,
                                       delivery=delivery, message=message, ros2_qos=ros2_qos))

    def service(self, srv_type: Any, name: str, handler: Callable[[Any], Any], *, inline: bool,
                ros2_only: bool = False) -> ServiceServer:
        return self._keep(ServiceServer(self._runtime, srv_type, self._resolve(name), handler, inline=inline,
                                        ros2_only=ros2_only))

    def client(self, srv_type: Any, name: str) -> Client:
        return self._keep(Client(self._runtime, srv_type, self._resolve(name)))

    def ros2_client(self, srv_type: Any, name: str) -> Ros2Client:
        return self._keep(Ros2Client(self._runtime, srv_type, self._resolve(name)))

    def action_server(self, action_type: Any, name: str, **kwargs: Any) -> ActionServer:
        return self._keep(ActionServer(self._runtime, action_type, self._resolve(name), **kwargs))

    def action_client(self, action_type: Any, name: str) -> ActionClient:
        return self._keep(ActionClient(self._runtime, action_type, self._resolve(name)))

    def destroy(self, entity: Any) -> None:
        try:
            entity.destroy()
        finally:
            if entity in self._entities:
                self._entities.remove(entity)

    def destroy_all(self) -> None:
        """Newest first; best effort (the node is going away)."""
        for entity in reversed(self._entities):
            try:
                entity.destroy()
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass
        self._entities.clear()
