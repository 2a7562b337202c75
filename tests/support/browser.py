"""Headless Chromium driven over its remote-debugging protocol (CDP), to look at the web viewer as a person does.

``HeadlessBrowser`` starts ``chromium --headless`` with ``--remote-debugging-port=0`` on loopback (Chromium
writes the port it picked to ``DevToolsActivePort`` in its profile directory), opens one page, and talks to
it over a WebSocket (``websocket-client``): ``navigate``, ``evaluate`` (``Runtime.evaluate``) and
``screenshot`` (``Page.captureScreenshot``). Raw CDP rather than Playwright: Playwright enables the
``Runtime`` domain, and with it every console message of the page is sent to the client (see
``HeadlessBrowser.__init__``).

``ViewerProbe`` reads what the Rerun web viewer shows: the page keeps its ``WebHandle`` in
``window._handle``, whose ``viewer_state()`` returns the Viewer Control API's state (protobuf): the open
recordings, their timelines with their ranges, and the time cursor. ``decode_viewer_state`` reads it with a
schema-less protobuf walk.
"""

from __future__ import annotations

import base64
import itertools
import json
import shutil
import signal
import struct
import subprocess
import tempfile
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import websocket

from bench.common import spawn, stop

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
# Software rendering (no GPU here). Mesa's llvmpipe through ANGLE's EGL backend draws a Rerun frame in about
# a third of the CPU time of Chromium's own SwiftShader (measured: ~240-330 ms against ~620-900 ms per frame
# of the web viewer, 1400x800); SwiftShader is the fallback where Mesa's EGL is missing.
RENDERERS = {
    "llvmpipe": ("--use-angle=gl-egl", "--use-gl=angle", "--ignore-gpu-blocklist", "--enable-gpu"),
    "swiftshader": ("--use-angle=swiftshader", "--enable-unsafe-swiftshader"),
}


def find_browser() -> str | None:
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


class CdpError(RuntimeError):
    pass


class HeadlessBrowser:
    """One headless Chromium with one page; ``close()`` ends it (a context manager too)."""

    def __init__(self, width: int = 1400, height: int = 800, browser: str | None = None,
                 timeout: float = 30.0, renderer: str = "llvmpipe", extra_args: list[str] | None = None) -> None:
        path = browser or find_browser()
        if path is None:
            raise CdpError("no Chromium found (Debian: apt-get install chromium)")
        self.profile = Path(tempfile.mkdtemp(prefix="zenroid_chromium_"))
        self.timeout = timeout
        self.ids = itertools.count(1)
        if renderer not in RENDERERS:
            raise CdpError(f"renderer '{renderer}': expected one of {', '.join(RENDERERS)}")
        self.proc = spawn(
            [path, "--headless=new", "--no-sandbox", "--remote-debugging-address=127.0.0.1",
             "--remote-debugging-port=0", f"--user-data-dir={self.profile}", "--no-first-run",
             "--no-default-browser-check", "--disable-extensions", "--disable-background-networking",
             *RENDERERS[renderer], "--hide-scrollbars",
             "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
             f"--window-size={width},{height}", *(a for a in extra_args or [] if a), "about:blank"],
            stderr=subprocess.DEVNULL)
        try:
            port = self._devtools_port()
            # No Origin header: Chromium refuses DevTools connections from origins it was not told to allow.
            # Text frames are JSON from our own browser: the pure-Python UTF-8 check of every frame (a
            # screenshot is ~1 MB of base64) is skipped.
            self.ws = websocket.create_connection(self._page_socket(port), timeout=timeout, suppress_origin=True,
                                                  skip_utf8_validation=True)
            self.call("Page.enable")
            # No "Runtime.enable": with it, every console message of the page is serialised to us. Rerun's
            # viewer writes ~12,800 console.debug lines while it translates its shaders, and that doubled a
            # late page's start-up (first view 14.9 s against 7.7 s, measured); a person's browser without
            # DevTools open does not pay it. Runtime.evaluate works without it.
            self.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1,
                      mobile=False)
        except Exception:
            self.close()
            raise

    def _devtools_port(self) -> int:
        marker = self.profile / "DevToolsActivePort"
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise CdpError(f"Chromium exited at start (status {self.proc.returncode})")
            if marker.is_file():
                lines = marker.read_text().split()
                if lines:
                    return int(lines[0])
            time.sleep(0.05)
        raise CdpError("Chromium did not open its DevTools port")

    def _page_socket(self, port: int) -> str:
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as reply:  # noqa: S310 - loopback
                    pages = [t for t in json.load(reply) if t.get("type") == "page"]
            except OSError:  # a Chromium starting on a loaded machine may not answer within 5 s: ask again
                pages = []
            if pages:
                return pages[0]["webSocketDebuggerUrl"]
            time.sleep(0.05)
        raise CdpError("Chromium has no page to attach to")

    def call(self, method: str, timeout: float | None = None, **params: Any) -> dict:
        """One CDP command; events that arrive meanwhile are skipped."""
        self.ws.settimeout(timeout or self.timeout)
        request_id = next(self.ids)
        try:
            self.ws.send(json.dumps({"id": request_id, "method": method, "params": params}))
            while True:
                message = json.loads(self.ws.recv())
                if message.get("id") == request_id:
                    break
        except websocket.WebSocketException as exc:  # closed by the browser, or no answer in time
            raise CdpError(f"{method}: {exc or type(exc).__name__}") from exc
        if "error" in message:
            raise CdpError(f"{method}: {message['error'].get('message', message['error'])}")
        return message.get("result", {})

    def navigate(self, url: str) -> None:
        self.call("Page.navigate", url=url)

    def evaluate(self, expression: str, await_promise: bool = False) -> Any:
        """The value of a JavaScript expression on the page (JSON-able values only)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                           awaitPromise=await_promise)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            text = details.get("exception", {}).get("description") or details.get("text", "")
            raise CdpError(f"page error: {text}")
        return result.get("result", {}).get("value")

    def screenshot(self, path: Path | None = None, timeout: float = 120.0) -> bytes:
        """A PNG of the page as it is drawn now (waits for the page's next frame). ``optimizeForSpeed``: a
        1400x800 PNG then takes ~0.3 s instead of ~3.5 s (its compression), so the picture is of a known moment."""
        data = base64.b64decode(self.call("Page.captureScreenshot", timeout=timeout, format="png",
                                          optimizeForSpeed=True)["data"])
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        return data

    def close(self) -> None:
        ws = getattr(self, "ws", None)
        if ws is not None:
            ws.close()
        stop(self.proc, 10, signal.SIGTERM)
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> HeadlessBrowser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- the Rerun web viewer's state ------------------------------------------------------------------------

def _varint(data: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        b = data[i]
        i += 1
        value |= (b & 0x7F) << shift
        if not b & 0x80:
            return value, i
        shift += 7


def parse_protobuf(data: bytes) -> list[tuple[int, Any]] | None:
    """``(field number, value)`` pairs; length-delimited values stay bytes. None if ``data`` is not protobuf."""
    fields: list[tuple[int, Any]] = []
    i = 0
    try:
        while i < len(data):
            key, i = _varint(data, i)
            number, wire = key >> 3, key & 7
            if number == 0:
                return None
            if wire == 0:
                value, i = _varint(data, i)
            elif wire == 1:
                value, i = struct.unpack_from("<q", data, i)[0], i + 8
            elif wire == 2:
                n, i = _varint(data, i)
                if i + n > len(data):
                    return None
                value, i = data[i:i + n], i + n
            elif wire == 5:
                value, i = struct.unpack_from("<i", data, i)[0], i + 4
            else:
                return None
            fields.append((number, value))
    except (IndexError, struct.error):
        return None
    return fields


def _text(value: Any) -> str | None:
    if isinstance(value, bytes):
        try:
            text = value.decode()
        except UnicodeDecodeError:
            return None
        return text if text.isprintable() else None
    return None


def _strings(value: bytes, depth: int = 0) -> list[str]:
    """Every printable string inside a message (nested messages searched too)."""
    direct = _text(value)
    found = [direct] if direct else []
    fields = parse_protobuf(value) if depth < 4 else None
    if fields:
        for _, inner in fields:
            if isinstance(inner, bytes):
                found += _strings(inner, depth + 1)
    return found


def _ints(value: bytes, depth: int = 0) -> list[int]:
    fields = parse_protobuf(value) if depth < 4 else None
    out: list[int] = []
    for _, inner in fields or []:
        if isinstance(inner, int):
            out.append(inner)
        elif isinstance(inner, bytes):
            out += _ints(inner, depth + 1)
    return out


@dataclass
class TimelineState:
    name: str
    end_ns: int | None  # the newest time the viewer has received on it


@dataclass
class RecordingState:
    store_id: str
    timelines: dict[str, TimelineState] = field(default_factory=dict)
    cursor_timeline: str | None = None
    cursor_ns: int | None = None  # where the time cursor is: what the views show


def decode_viewer_state(data: bytes) -> list[RecordingState]:
    """The recordings in a Viewer Control ``GetViewerStateResponse`` (field 3: ``ViewerRecording`` =
    store_id 1, timelines 2 (``ViewerTimeline``: timeline 1 {name 1}, time_type 2, time_range 3 {start 1,
    end 2}), current_time 3 (``TimeCursor``: timeline 1 {name 1}, time_type 2, time 3 {time 1}))."""
    recordings = []
    for number, value in parse_protobuf(data) or []:
        if number != 3 or not isinstance(value, bytes):
            continue
        fields = parse_protobuf(value) or []
        store_id = next((_text(v) for n, v in fields if n == 1), None) or ""
        recording = RecordingState(store_id)
        for n, v in fields:
            if n == 2 and isinstance(v, bytes):
                names = [s for s in _strings(v) if s]
                parts = dict(parse_protobuf(v) or [])
                time_range = parts.get(3)
                end = _ints(time_range)[-1] if isinstance(time_range, bytes) and _ints(time_range) else None
                if names:
                    recording.timelines[names[0]] = TimelineState(names[0], end)
            elif n == 3 and isinstance(v, bytes):
                parts = dict(parse_protobuf(v) or [])
                names = _strings(parts[1]) if isinstance(parts.get(1), bytes) else []
                recording.cursor_timeline = names[0] if names else None
                when = parts.get(3)
                ints = _ints(when) if isinstance(when, bytes) else []
                recording.cursor_ns = ints[0] if ints else (0 if isinstance(when, bytes) else None)
        recordings.append(recording)
    return recordings


class ViewerProbe:
    """The served Rerun web viewer in a headless browser: its time cursor and received range, screenshots."""

    def __init__(self, browser: HeadlessBrowser, viewer_url: str) -> None:
        self.browser = browser
        browser.navigate(viewer_url)

    def ready(self) -> bool:
        return bool(self.browser.evaluate("typeof window._handle === 'object' && window._handle !== null"))

    def wait_ready(self, timeout: float = 90.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.ready():
                return
            time.sleep(0.25)
        raise CdpError("the web viewer did not start in the page")

    def state(self, timeout: float = 10.0) -> list[RecordingState]:
        """The viewer's state; while it paints a frame (slow on a software renderer) it cannot answer, so
        this asks again until ``timeout``."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                raw = self.browser.evaluate("Array.from(window._handle.viewer_state())")
                return decode_viewer_state(bytes(raw or []))
            except CdpError as exc:
                if "busy painting" not in str(exc) or time.monotonic() > deadline:
                    raise
                time.sleep(0.05)

    def pause(self) -> None:
        """Press Space over the page: the viewer's play/pause key. The time cursor stops where it is (no longer
        following the newest data), so a picture taken next shows a known time."""
        self.browser.call("Input.dispatchMouseEvent", type="mouseMoved", x=200, y=400)
        self.browser.call("Input.dispatchKeyEvent", type="keyDown", key=" ", code="Space", windowsVirtualKeyCode=32,
                          text=" ")
        self.browser.call("Input.dispatchKeyEvent", type="keyUp", key=" ", code="Space", windowsVirtualKeyCode=32)

    def recording(self, app_id: str = "zenroid_viz") -> RecordingState | None:
        for recording in self.state():
            if recording.store_id.startswith(f"Recording:{app_id}:"):
                return recording
        return None
