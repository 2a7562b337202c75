"""``NodeRuntime``: what an endpoint (publisher, subscription, service, client, action, latched topic) needs
from the node that owns it, and nothing more.

Endpoints depend on this interface, not on ``Node``: ``nodes/core/node.py`` imports the endpoint modules,
never the other way round, so there is no import cycle to hide. ``Node`` satisfies it.
"""

from __future__ import annotations

from typing import Any, Protocol

import zenoh

from nodes.core.executor import Executor
from nodes.core.log import Logger
from nodes.core.presence import GraphPresence


class NodeRuntime(Protocol):
    session: zenoh.Session
    logger: Logger
    executor: Executor      # callbacks run through it, one at a time
    presence: GraphPresence  # graph tokens and the ROS 2 twin of each endpoint

    @property
    def closed(self) -> bool:
        """True once the node is being destroyed: publishing becomes a no-op."""
        ...

    def now_msg(self) -> Any:
        """The node clock as builtin_interfaces/Time (action goal stamps)."""
        ...
