"""A node's presence in the graph: its liveliness tokens (the node and each endpoint) and its ROS 2 twin.

Endpoints announce themselves through ``token`` and ask ``mirror`` for their twin on the ROS 2 wire
(``nodes/core/ros2``); ``close`` takes the whole presence down when the node is destroyed.
"""

from __future__ import annotations

from typing import Any

import zenoh

from nodes.core import graph, ros2
from nodes.core.log import Logger


class _EndpointToken:
    """An endpoint's liveliness token: undeclared, it is also forgotten by the presence (an endpoint created and
    destroyed over and over, as a spawned robot's, must not leave its token behind)."""

    __slots__ = ("_token", "_live")

    def __init__(self, token: Any, live: set) -> None:
        self._token = token
        self._live = live
        live.add(self)

    def undeclare(self) -> None:
        self._live.discard(self)
        self._token.undeclare()


class GraphPresence:
    def __init__(self, session: zenoh.Session, fully_qualified_name: str, logger: Logger) -> None:
        # session, session_id, fully_qualified_name and logger are what ``ros2.attach`` reads
        self.session = session
        self.session_id = str(session.info.zid())
        self.fully_qualified_name = fully_qualified_name
        self.logger = logger
        self._tokens: list[Any] = [session.liveliness().declare_token(
            graph.node_key(self.session_id, fully_qualified_name))]
        self._endpoint_tokens: set[_EndpointToken] = set()
        self._ros2 = ros2.attach(self)  # the ROS 2 wire (rmw_zenoh) presence, None when off

    def token(self, kind: str, key: str, type_name: str) -> Any:
        """Announce one endpoint (``kind`` as in ``graph.KINDS``); the token is undeclared by ``close`` at the
        latest, or earlier by the endpoint itself."""
        return _EndpointToken(self.session.liveliness().declare_token(
            graph.endpoint_key(kind, self.session_id, self.fully_qualified_name, key, type_name)),
            self._endpoint_tokens)

    def mirror(self, endpoint: Any) -> Any | None:
        """The endpoint's twin on the ROS 2 wire (an object with ``close()``), None when not mirrored."""
        return self._ros2.mirror(endpoint) if self._ros2 is not None else None

    def ros2_client(self, key: str, type_name: str) -> Any:
        """A client of the ROS 2 service ``/key`` on rmw_zenoh's wire; RuntimeError when the wire is off."""
        if self._ros2 is None:
            raise RuntimeError(f"service '/{key}': the ROS 2 wire is off in this process ({ros2.ENV_ENABLE}=0)")
        return self._ros2.service_client(key, type_name)

    def close(self) -> None:
        if self._ros2 is not None:
            self._ros2.close()
        for token in [*self._endpoint_tokens, *self._tokens]:
            try:
                token.undeclare()
            except Exception:  # noqa: BLE001 - best effort on the way out (already undeclared, session closing)
                pass
