"""Size limits before decoding, over a real router: an oversized message or request is refused (logged on
rosout, an error reply naming the size), a flood far beyond it never reaches the node at all (Zenoh's own
``max_message_size``), and the links keep working."""

from __future__ import annotations

import threading
import time

import msgpack
import zenoh

import msgs
from nodes.core import Node
from nodes.core.session import DEFAULT_MAX_PAYLOAD, open_peer
from tests.conftest import wait_until

Trigger = msgs.get_type("std_srvs/srv/Trigger")
SetBool = msgs.get_type("std_srvs/srv/SetBool")
String = msgs.get_type("std_msgs/msg/String")
Log = msgs.get_type("rcl_interfaces/msg/Log")


def test_oversized_messages_and_requests_are_refused_before_decoding(router: str) -> None:
    server = Node("limits_server", connect=[router])
    received: list[str] = []
    logs: list[str] = []
    lock = threading.Lock()
    client = open_peer([router])
    try:
        server.create_subscription(String, "/limits/topic", lambda m: received.append(m.data))
        server.create_service(SetBool, "/limits/service", lambda r: SetBool.Response(success=r.data))

        def on_log(sample: zenoh.Sample) -> None:
            with lock:
                logs.append(msgs.decode(Log, sample.payload.to_bytes()).msg)

        log_sub = client.declare_subscriber("rosout", on_log)
        time.sleep(0.5)   # routes form

        def call(payload: bytes, timeout: float = 5.0) -> tuple[str, object]:
            for reply in client.get("limits/service", payload=payload, timeout=timeout):
                if reply.ok is not None:
                    return "ok", msgpack.unpackb(reply.ok.payload.to_bytes())
                raw = reply.err.payload.to_bytes()
                try:
                    return "err", msgpack.unpackb(raw)
                except ValueError:   # not one of our error maps: Zenoh's own ("Timeout")
                    return "zenoh", raw.decode(errors="replace")
            return "none", None

        big = msgs.encode(String(data="x" * (DEFAULT_MAX_PAYLOAD + 10)))
        client.put("limits/topic", big, congestion_control=zenoh.CongestionControl.BLOCK)
        kind, answer = call(msgpack.packb({"data": True, "pad": "y" * (DEFAULT_MAX_PAYLOAD + 10)}))
        assert kind == "err" and "over the 4194304-byte limit" in answer["error"], answer
        # 40 MB: beyond what Zenoh itself takes from a link; dropped there, no reply, the link stays up
        kind, answer = call(b"z" * (40 * 1024 * 1024), timeout=2.0)
        assert kind in ("none", "zenoh"), (kind, answer)
        client.put("limits/topic", msgs.encode(String(data="small")))
        wait_until(lambda: received == ["small"], timeout=10, message="the small message after the big ones")
        assert call(msgpack.packb({"data": True})) == ("ok", {"success": True, "message": ""})
        wait_until(lambda: any("payload: " in line and "over the" in line for line in logs), timeout=10,
                   message="the dropped message on rosout")
        with lock:
            assert any("bad request" in line and "4194304-byte limit" in line for line in logs), logs
            assert all(len(line) < 3000 for line in logs)
        log_sub.undeclare()
    finally:
        client.close()
        server.destroy()
