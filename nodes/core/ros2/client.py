"""A client of a service on rmw_zenoh's wire: CDR requests on the service's data key, with the client token
(``SC``) ROS 2's graph shows, the attachment rmw_zenoh needs to answer, and the first reply taken.

It reaches any ROS 2 service server: rclcpp/rclpy nodes over rmw_zenoh, zenoh-ros2-sdk servers, and the
services our nodes offer on the ROS 2 wire (including those offered there only, such as rcl_interfaces'
parameter services).
"""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

import msgpack
import zenoh

from msgs import cdr
from msgs.compiled import packb
from nodes.core.ros2 import attachment, names
from nodes.core.ros2.mirror import Entity, MirrorOwner

_CDR = zenoh.Encoding.APPLICATION_CDR


class ServiceCallError(RuntimeError):
    """No server answered, or it answered with an error."""


class ServiceClient:
    def __init__(self, owner: MirrorOwner, ros_name: str, srv_type: str) -> None:
        self.owner = owner
        self.ros_name = ros_name
        self.request_type, self.response_type = f"{srv_type}_Request", f"{srv_type}_Response"
        self.entity = Entity(owner, names.CLIENT, ros_name, srv_type)
        self._server_tokens = (f"{names.ADMIN_SPACE}/{owner.domain}/*/*/*/{names.SERVICE}/*/*/*/"
                               f"{names.mangle(ros_name)}/{names.dds_type(srv_type)}/*/*")
        self._hash = self.entity.data_key.rsplit("/", 1)[-1]
        self._seq = itertools.count(1)
        self._lock = threading.Lock()

    def call(self, request: dict[str, Any], timeout: float) -> dict[str, Any]:
        """The response (a plain map) to ``request`` (a plain map, as ``msgs.encode`` packs it).

        A query that finds no server returns at once; it is retried until ``timeout`` because a fresh
        session needs a few milliseconds before routes to existing queryables form."""
        payload = cdr.encode(self.request_type, request)
        with self._lock:
            sequence = next(self._seq)
        deadline = time.monotonic() + timeout
        while True:
            remaining = max(0.01, deadline - time.monotonic())
            replies = self.owner.session.get(
                self.entity.data_key, payload=payload, encoding=_CDR, timeout=remaining,
                attachment=attachment.pack(sequence, self.entity.gid), target=zenoh.QueryTarget.BEST_MATCHING)
            for reply in replies:
                if reply.ok is not None:
                    try:
                        return cdr.decode(self.response_type, reply.ok.payload.to_bytes())
                    except cdr.CdrError as exc:
                        raise ServiceCallError(f"service '{self.ros_name}' sent a bad response: {exc}") from None
                raise ServiceCallError(f"service '{self.ros_name}' returned an error: "
                                       f"{reply.err.payload.to_bytes().decode(errors='replace')}")
            if time.monotonic() >= deadline - 0.02:
                break
            time.sleep(0.02)
        raise ServiceCallError(f"no response from service '{self.ros_name}' within {timeout:g} s "
                               "(is its server running on the ROS 2 wire?)")

    def call_msgpack(self, request: bytes, timeout: float) -> bytes:
        """``call`` for a msgpack request; the response as msgpack (what our endpoints decode)."""
        return packb(self.call(msgpack.unpackb(request, raw=False), timeout))

    def server_is_ready(self) -> bool:
        """A server of this service, type and type hash announces itself (its ``SS`` token)."""
        for reply in self.owner.session.liveliness().get(self._server_tokens, timeout=0.5):
            if reply.ok is not None and str(reply.ok.key_expr).split("/")[11] == self._hash:
                return True
        return False

    def close(self) -> None:
        self.entity.close()
