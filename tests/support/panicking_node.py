"""A node that makes Zenoh panic on request: ``<name>/panic`` (std_srvs/Empty) declares a publisher on a
key too long for one Zenoh batch, which panics inside zenoh (``DidntWrite``) and poisons the session, as a
key built from a hostile name once did in the simulator. ``python -m tests.support.panicking_node``."""

from __future__ import annotations

import sys
from typing import Any

import msgs
from nodes.core import Node, run_node

Empty = msgs.get_type("std_srvs/srv/Empty")


class PanickingNode(Node):
    default_name = "panicker"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(kwargs.pop("node_name", "panicker"), **kwargs)
        self.create_service(Empty, "~/panic", self._panic)
        self.logger.info("ready")

    def _panic(self, _request: Any) -> Any:
        self.session.declare_publisher("x" * 100_000)   # past every check: straight onto the session
        return Empty.Response()


if __name__ == "__main__":
    sys.exit(run_node(PanickingNode))
