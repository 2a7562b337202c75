"""Where the recording goes: a native viewer, a served web viewer, and/or an ``.rrd`` file.

Headless by default when there is no display. The web viewer is hosted by Rerun's own CLI
(``python -m rerun --serve-web --bind 127.0.0.1``) because ``rr.serve_web_viewer`` binds every
interface; our recording streams into that server over gRPC on loopback.
"""

from __future__ import annotations

import ctypes
import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import rerun as rr


def has_display() -> bool:
    """A native viewer can open: an X11 or Wayland display on Linux, always elsewhere."""
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _load_prctl():
    """libc's prctl, looked up here and not in the forked child (no imports between fork and exec)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL("libc.so.6", use_errno=True).prctl
    except OSError:
        return None


_PRCTL = _load_prctl()
PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    if _PRCTL is not None:
        _PRCTL(PR_SET_PDEATHSIG, signal.SIGTERM)


def rerun_cli() -> list[str]:
    """The Rerun CLI binary itself: ``python -m rerun`` is a wrapper that runs it as a *child*, so
    terminating the wrapper would orphan the server."""
    try:
        import rerun_cli as package

        binary = Path(package.__file__).parent / ("rerun.exe" if sys.platform.startswith("win") else "rerun")
        if binary.is_file():
            return [str(binary)]
    except ImportError:
        pass
    return [sys.executable, "-m", "rerun"]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_port(port: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.05)
    return False


# What the web viewer server keeps for viewers that connect later. A viewer takes in everything the server
# sends it, in order, before it shows the present: the layouts (the server always keeps every blueprint, and
# counts them toward this limit), then the kept rows, then whatever arrived meanwhile; a software-rendered page
# takes in only a few chunks per frame at 1-3 frames per second (bench/viz.py, docs/viewer.md), so every
# kept row delays the present. The server drops the oldest data beyond the limit before it stores a new
# message, and the layouts alone are larger than this, so it keeps just the newest message: nothing the
# viewer logs is static, every robot row holds the whole robot, its markers and its plotted values, and
# the ground is the layout's grid, so that one row draws a complete scene (the plots fill from there).
SERVER_HISTORY = "1KiB"


@dataclass
class OutputPlan:
    """What the user asked for, resolved against the environment."""

    save: Path | None = None
    serve: bool = False
    spawn: bool = False
    web_port: int = 9090
    grpc_port: int = 9876
    server_history: str = SERVER_HISTORY
    bind: str = "127.0.0.1"   # the web server's listening address (a container publishing it: 0.0.0.0)
    notes: list[str] = field(default_factory=list)

    @classmethod
    def resolve(cls, save: str | None, serve: bool, spawn: bool, headless: bool | None,
                web_port: int, grpc_port: int, server_history: str | None = None,
                bind: str = "127.0.0.1") -> OutputPlan:
        plan = cls(save=Path(save) if save else None, serve=serve, spawn=spawn, web_port=web_port,
                   grpc_port=grpc_port, server_history=server_history or SERVER_HISTORY, bind=bind)
        display = has_display() if headless is None else not headless
        if plan.spawn and not display:
            # rr.spawn() without a display silently loses the data (FACTS): serve instead.
            plan.spawn, plan.serve = False, True
            plan.notes.append("no display: serving the web viewer instead of spawning the native viewer")
        if not (plan.save or plan.serve or plan.spawn):
            if display:
                plan.spawn = True
            else:
                plan.serve = True
                plan.notes.append("no display: serving the web viewer")
        return plan


class Output:
    """Attaches the sinks of an ``OutputPlan`` to a recording; ``close()`` flushes and stops the server."""

    def __init__(self, recording: rr.RecordingStream, plan: OutputPlan) -> None:
        self.recording = recording
        self.plan = plan
        self.server: subprocess.Popen | None = None
        self.viewer_url = ""
        sinks: list = []
        if plan.save:
            plan.save.parent.mkdir(parents=True, exist_ok=True)
            sinks.append(rr.FileSink(str(plan.save)))
        if plan.serve:
            grpc_url = self._start_web_server()
            sinks.append(rr.GrpcSink(grpc_url))
        if plan.spawn:
            sinks.append(rr.GrpcSink(self._spawn_viewer()))
        if sinks:
            recording.set_sinks(*sinks)   # no start-up layout: the viewer sends one once joints are known

    def _spawn_viewer(self) -> str:
        """The native viewer, started like ``rr.spawn`` (detached: the window outlives the node) but with
        its gRPC server on loopback: ``rr.spawn`` binds it to every interface."""
        port = free_port() if self.plan.serve else (self.plan.grpc_port or free_port())
        subprocess.Popen([*rerun_cli(), "--bind", "127.0.0.1", "--port", str(port), "--expect-data-soon",
                          "--hide-welcome-screen"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        if not wait_for_port(port, 20.0):
            raise RuntimeError(f"the Rerun viewer did not start listening on port {port}")
        return f"rerun+http://127.0.0.1:{port}/proxy"

    def _start_web_server(self) -> str:
        grpc_port = self.plan.grpc_port or free_port()
        web_port = self.plan.web_port or free_port()
        self.server = subprocess.Popen(
            [*rerun_cli(), "--serve-web", "--bind", self.plan.bind, "--port", str(grpc_port),
             "--web-viewer-port", str(web_port), "--server-memory-limit", self.plan.server_history],
            # Its own session: a Ctrl-C (SIGINT to the terminal's process group) or a launcher stopping the
            # group reaches the viewer only, which sends what it still holds and then stops the server
            # (``close``); were the server stopped first, the SDK would log "gRPC connection severed" errors.
            # On Linux the server also gets SIGTERM if the viewer dies without cleaning up (kill -9).
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=_die_with_parent,
            start_new_session=True,
        )
        if not wait_for_port(grpc_port, 20.0) or self.server.poll() is not None:
            self.close()
            raise RuntimeError(f"the Rerun web viewer server did not start on ports {grpc_port}/{web_port}")
        grpc_url = f"rerun+http://127.0.0.1:{grpc_port}/proxy"
        self.viewer_url = f"http://127.0.0.1:{web_port}/?url={grpc_url.replace('+', '%2B')}"
        return grpc_url

    def close(self) -> None:
        try:
            self.recording.flush()
            if self.server is not None:
                # Let go of the gRPC sink before its server stops (rows logged later are buffered, not sent).
                self.recording.disconnect()
        except Exception:  # noqa: BLE001 - shutting down: nothing useful to do with a flush error
            pass
        if self.server is not None and self.server.poll() is None:
            self.server.terminate()
            try:
                self.server.wait(5)
            except subprocess.TimeoutExpired:
                self.server.kill()
                self.server.wait()
        self.server = None
