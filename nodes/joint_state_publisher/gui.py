"""``joint_state_publisher_gui``: the joint state publisher with one slider per movable joint, within its
limits, on a web page served beside the viewer (our users are headless). The page's URL is printed, as the
viewer's is: ``joint_state_publisher_gui: http://127.0.0.1:PORT/``.

Parameters beside the publisher's: ``port`` (0: any free port), ``bind`` (default loopback only).
The page asks ``GET /joints`` for the joints and sends ``POST /joint`` ``{"name", "position"}`` as a slider
moves; ``POST /center`` puts every joint back at its start.
"""

from __future__ import annotations

import json
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from nodes.core import run_node
from nodes.joint_state_publisher.node import JointStatePublisher

PAGE = (Path(__file__).parent / "page.html").read_bytes()
MAX_BODY = 4096


class JointStatePublisherGui(JointStatePublisher):
    default_name = "joint_state_publisher_gui"

    def __init__(self, **kwargs: Any) -> None:
        self.version = 0
        super().__init__(**kwargs)
        port = self.declare_parameter("port", 0, min_value=0, max_value=65535, description="web page port (0: any)")
        bind = self.declare_parameter("bind", "127.0.0.1", description="address the page is served on")
        node = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # requests are not news
                pass

            def _reply(self, status: int, body: bytes, kind: str = "application/json") -> None:
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                if self.path in ("/", "/index.html"):
                    self._reply(200, PAGE, "text/html; charset=utf-8")
                elif self.path == "/joints":
                    self._reply(200, json.dumps(node.state()).encode())
                else:
                    self._reply(404, b'{"error": "not found"}')

            def do_POST(self) -> None:  # noqa: N802
                length = int(self.headers.get("Content-Length") or 0)
                if length > MAX_BODY:
                    self._reply(413, b'{"error": "request too large"}')
                    return
                try:
                    body = json.loads(self.rfile.read(length) or b"{}")
                except ValueError:
                    self._reply(400, b'{"error": "not JSON"}')
                    return
                if self.path == "/joint" and isinstance(body, dict):
                    try:
                        error = node.set_position(str(body.get("name")), float(body.get("position")))
                    except (TypeError, ValueError):
                        error = "position must be a number"
                elif self.path == "/center":
                    error = node.center()
                else:
                    self._reply(404, b'{"error": "not found"}')
                    return
                if error:
                    node.logger.warn_throttle(2.0, f"page request refused: {error}", key="gui-request")
                self._reply(400 if error else 200, json.dumps({"error": error} if error else {"ok": True}).encode())

        try:
            self.server = ThreadingHTTPServer((bind, port), Handler)
        except OSError as exc:
            raise ValueError(f"cannot serve the sliders page on {bind}:{port}: {exc}") from None
        self.server.daemon_threads = True
        threading.Thread(target=self.server.serve_forever, name="jsp-gui-http", daemon=True).start()
        host = "127.0.0.1" if bind in ("0.0.0.0", "") else bind
        self.url = f"http://{host}:{self.server.server_address[1]}/"
        print(f"joint_state_publisher_gui: {self.url}", flush=True)
        self.logger.info(f"sliders page at {self.url}")

    def on_joints_changed(self) -> None:
        self.version += 1

    def state(self) -> dict[str, Any]:
        names, positions = self.current()
        values = dict(zip(names, positions))
        with self.lock:
            joints = [{"name": j.name, "lower": j.lower, "upper": j.upper, "continuous": j.continuous,
                       "position": values.get(j.name, j.zero)} for j in self.joints]
        return {"version": self.version, "joints": joints, "mimic": sorted(self.mimics)}

    def center(self) -> None:
        with self.lock:
            self.positions = {j.name: j.zero for j in self.joints}

    def on_process_exit(self) -> None:
        self.server.shutdown()
        self.server.server_close()
        super().on_process_exit()


def main(argv: list[str] | None = None) -> int:
    return run_node(JointStatePublisherGui, argv)


if __name__ == "__main__":
    sys.exit(main())
