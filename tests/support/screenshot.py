"""Screenshot of the served web viewer in headless Chromium (regenerates ``docs/viz.png``).

``python -m tests.support.screenshot [--out docs/viz.png] [--settle 6] [--render 15]
[--source humanoid --launch-arg robot:=g1 --viz-param robots:=[g1]]`` runs a router, the state
publisher, the viz feeder and ``python -m nodes.viz --serve`` on free loopback ports, lets the robot move,
then loads the viewer page in headless Chromium and saves the picture. Chromium's ``--screenshot`` fires
on the page's load event, before the WebAssembly viewer has drawn anything; so the page we load wraps the
viewer in an iframe next to an image that our own little server answers only after ``--render`` seconds.
Exit status 3 when no Chromium is installed (Debian: ``apt-get install chromium``).
"""

from __future__ import annotations

import argparse
import http.server
import subprocess
import sys
import threading
import time
from html import escape
from pathlib import Path

from bench.common import child_env, free_port, spawn, stop_all
from nodes.core.session import loopback_endpoint, open_router
from nodes.share import robot_file
from tests.support.browser import RENDERERS, find_browser

__all__ = ["find_browser", "take"]


def delayed_page_server(viewer_url: str, render_seconds: float) -> http.server.ThreadingHTTPServer:
    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args) -> None:  # quiet
            pass

        def do_GET(self) -> None:  # noqa: N802 - http.server's naming
            if self.path.startswith("/hold"):
                time.sleep(render_seconds)  # holds the load event while the viewer renders
                self.send_response(204)
                self.end_headers()
                return
            body = (f'<html><body style="margin:0;background:#111"><iframe src="{escape(viewer_url)}" '
                    'style="border:0;width:100vw;height:100vh"></iframe>'
                    '<img src="/hold" style="display:none"></body></html>').encode()
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    server = http.server.ThreadingHTTPServer(("127.0.0.1", free_port()), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def take(out: Path, settle: float, render: float, size: str = "1400,800", source: str = "feeder",
         viz_params: tuple[str, ...] = (), launch_args: tuple[str, ...] = ()) -> int:
    browser = find_browser()
    if browser is None:
        print("no Chromium found (Debian: apt-get install chromium)", file=sys.stderr)
        return 3
    zenoh_port, web_port, grpc_port = free_port(), free_port(), free_port()
    router = open_router(zenoh_port)
    env = child_env({"ZENOH_CONNECT": loopback_endpoint(zenoh_port)})
    procs: list[subprocess.Popen] = []

    def start(*argv: str) -> subprocess.Popen:
        proc = spawn([sys.executable, "-m", *argv], env=env, stdout=subprocess.PIPE, text=True)
        procs.append(proc)
        return proc

    try:
        if source == "humanoid":  # the real main job: DART, controller manager, joint commander
            router.close()  # the launcher hosts its own router on the port
            env.pop("ZENOH_CONNECT")
            launch = start("launch", "humanoid.yaml", "gui:=false", "mode:=realtime", f"zenoh_port:={zenoh_port}",
                           *launch_args)
            threading.Thread(target=lambda: launch.stdout.read(), daemon=True).start()
            env["ZENOH_CONNECT"] = loopback_endpoint(zenoh_port)
            time.sleep(8.0)
        else:
            start("nodes.state_publisher", "--ns", "humanoid",
                  "--param", f"robot_description_file:={robot_file('humanoid')}")
        viz = start("nodes.viz", "--serve", "--web-port", str(web_port), "--grpc-port", str(grpc_port),
                    *(arg for param in viz_params for arg in ("--param", param)))
        viewer_url = ""
        deadline = time.monotonic() + 60
        while not viewer_url and time.monotonic() < deadline and viz.poll() is None:
            line = viz.stdout.readline()
            if line.startswith("Rerun web viewer: "):
                viewer_url = line.split(": ", 1)[1].strip()
        if not viewer_url:
            print("the visualiser did not report its web viewer URL", file=sys.stderr)
            return 1
        threading.Thread(target=lambda: viz.stdout.read(), daemon=True).start()  # keep its pipe drained
        if source == "feeder":
            feeder = start("tests.support.viz_feeder", "--param", "robots:=[humanoid]")
            time.sleep(settle)
            # Freeze the motion so the viewer (slow on a software rasteriser) can catch up to a still pose.
            feeder.send_signal(2)
        else:
            time.sleep(settle)
        page = delayed_page_server(viewer_url, render)
        out.parent.mkdir(parents=True, exist_ok=True)
        result = subprocess.run(
            [browser, "--headless=new", "--no-sandbox", *RENDERERS["llvmpipe"], "--hide-scrollbars", f"--window-size={size}", f"--screenshot={out}",
             f"http://127.0.0.1:{page.server_address[1]}/"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=render + 90, check=False)
        page.shutdown()
        if result.returncode != 0 or not out.is_file():
            print(f"chromium failed (exit {result.returncode})", file=sys.stderr)
            return 1
        print(f"saved {out} ({out.stat().st_size} bytes)")
        return 0
    finally:
        stop_all(procs[::-1], timeout=15)  # SIGINT: nodes close their sessions, the visualiser its server
        try:
            router.close()
        except Exception:  # noqa: BLE001 - already closed for the launcher's own router
            pass


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.support.screenshot", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/viz.png"), help="where the picture goes (default: docs/viz.png under the current directory)")
    parser.add_argument("--settle", type=float, default=5.0, help="s of motion before the screenshot")
    parser.add_argument("--render", type=float, default=30.0, help="s the viewer gets to load and draw")
    parser.add_argument("--source", choices=("feeder", "humanoid"), default="feeder",
                        help="feeder: state publisher + viz feeder; humanoid: launch/humanoid.yaml (DART)")
    parser.add_argument("--viz-param", action="append", default=[], metavar="NAME:=VALUE",
                        help="a parameter of the viewer node (repeatable), e.g. plots:=[camera] for the camera tab")
    parser.add_argument("--launch-arg", action="append", default=[], metavar="NAME:=VALUE",
                        help="an argument of launch/humanoid.yaml with --source humanoid (repeatable), e.g. robot:=g1 "
                             "(then --viz-param robots:=[g1])")
    args = parser.parse_args(argv)
    return take(args.out, args.settle, args.render, source=args.source, viz_params=tuple(args.viz_param),
                launch_args=tuple(args.launch_arg))


if __name__ == "__main__":
    raise SystemExit(main())
