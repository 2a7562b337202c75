"""The served web viewer loads in headless Chromium and draws something (regenerates nothing in docs/)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from nodes.viz.screenshot import find_browser

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
@pytest.mark.skipif(find_browser() is None, reason="no Chromium installed (Debian: apt-get install chromium)")
def test_served_web_viewer_renders_in_headless_chromium(tmp_path: Path) -> None:
    out = tmp_path / "viz.png"
    result = subprocess.run([sys.executable, "-m", "nodes.viz.screenshot", "--out", str(out), "--settle", "3",
                             "--render", "15"], cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout + result.stderr
    image = pytest.importorskip("PIL.Image").open(out).convert("RGB")
    assert image.size == (1400, 800)
    left = image.crop((0, 40, 840, 770)).getcolors(maxcolors=1 << 20)  # the 3-D view
    # The ground (our grey box, shaded), covering a good part of the view: the scene was drawn.
    ground = sum(n for n, (r, g, b) in left if 60 <= r <= 120 and 0 <= g - r <= 12 and 0 <= b - r <= 20)
    assert ground > 50_000, f"no ground in the 3-D view ({ground} grey pixels): viewer not drawn"
    # The robot's torso blue (URDF material 'blue', shaded) is somewhere in the 3-D view on the left.
    bluish = sum(n for n, (r, g, b) in left if b > 120 and b > r + 60 and b > g + 30)
    assert bluish > 2000, f"no robot torso in the 3-D view ({bluish} blue pixels)"


# -- the main job's viewer, live ------------------------------------------------------------------------
KNEE_GREEN = (90, 200, 120)  # PALETTE[3]: the knee, 4th joint of the "left leg" plot
HIP_YAW_RED = (230, 85, 70)  # PALETTE[0]: left_hip_yaw, which stays at 0 in the knee bend


def _rightmost(image, box: tuple[int, int, int, int], rgb: tuple[int, int, int]) -> tuple[int, int] | None:
    """(x, y) of the rightmost pixel of colour ``rgb`` (±30 per channel) inside ``box``."""
    left, top, right, bottom = box
    pixels = image.load()
    for x in range(right - 1, left - 1, -1):
        ys = [y for y in range(top, bottom) if all(abs(c - w) <= 30 for c, w in zip(pixels[x, y], rgb))]
        if ys:
            return x, sum(ys) // len(ys)
    return None


@pytest.mark.slow
@pytest.mark.skipif(find_browser() is None, reason="no Chromium installed (Debian: apt-get install chromium)")
@pytest.mark.xfail(strict=False, reason=(
    "not met yet on a loaded 2-core machine: bench/viz.py measured the software-rendered page 95-127 s behind "
    "at load average 9-26 (README, Visualiser); the assertions stay so an XPASS shows when it is met"))
def test_main_job_viewer_shows_the_present_pose(tmp_path: Path, zenoh_port: int) -> None:
    """After ~20 s of the main job, a page opened then shows the simulation's present (within 1 s), and the
    knee in the picture (the left-leg plot at the cursor) is the knee of joint_states at that sim time."""
    import io
    import json
    import os
    import re
    import threading
    import time

    import msgpack
    import zenoh

    from nodes.viz.browser import HeadlessBrowser, ViewerProbe

    image_module = pytest.importorskip("PIL.Image")
    env = {k: v for k, v in os.environ.items() if k not in ("ZENOH_CONNECT", "ZENOH_CONFIG", "DISPLAY",
                                                             "WAYLAND_DISPLAY")}
    out = tmp_path / "launch.out"
    launch = subprocess.Popen([sys.executable, "-m", "launch", "humanoid.yaml", "mode:=realtime",
                               f"zenoh_port:={zenoh_port}", "viewer_args:=--serve --web-port 0 --grpc-port 0",
                               "--log-dir", str(tmp_path / "logs")], cwd=ROOT, env=env, stdout=open(out, "wb"),
                              stderr=subprocess.STDOUT, start_new_session=True)
    knees: dict[int, float] = {}  # sim time (ms) -> left_knee, from joint_states
    clock = {"now": 0.0}
    lock = threading.Lock()
    session = None
    try:
        deadline = time.monotonic() + 90
        while not re.search(r"Rerun web viewer: (\S+)", out.read_text(errors="replace")):
            assert launch.poll() is None and time.monotonic() < deadline, out.read_text(errors="replace")
            time.sleep(0.2)
        url = re.search(r"Rerun web viewer: (\S+)", out.read_text(errors="replace")).group(1)
        config = zenoh.Config()
        config.insert_json5("mode", json.dumps("peer"))
        config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{zenoh_port}"]))
        config.insert_json5("scouting/multicast/enabled", "false")
        session = zenoh.open(config)

        def on_state(sample) -> None:
            msg = msgpack.unpackb(sample.payload.to_bytes())
            stamp = msg["header"]["stamp"]
            with lock:
                knees[round((stamp["sec"] + stamp["nanosec"] * 1e-9) * 1000)] = msg["position"][
                    msg["name"].index("left_knee")]

        def on_clock(sample) -> None:
            stamp = msgpack.unpackb(sample.payload.to_bytes())["clock"]
            clock["now"] = stamp["sec"] + stamp["nanosec"] * 1e-9

        subs = [session.declare_subscriber("humanoid/joint_states", on_state),
                session.declare_subscriber("sim/clock", on_clock)]
        time.sleep(20.0)  # the main job runs for a while before anyone looks
        with HeadlessBrowser(timeout=120) as browser:
            page = ViewerProbe(browser, url)
            page.wait_ready(120)
            checked = []
            deadline = time.monotonic() + 150
            while len(checked) < 2 and time.monotonic() < deadline:
                shot = browser.screenshot()
                recording = page.recording()
                now = clock["now"]
                if recording is None or recording.cursor_timeline != "sim_time" or not recording.cursor_ns:
                    time.sleep(1.0)
                    continue
                cursor = recording.cursor_ns * 1e-9
                with lock:
                    window = [v for t, v in knees.items() if abs(t / 1000 - cursor) <= 0.4]
                settled = window and (min(window) > 0.3 or max(window) < 0.05)
                if not settled:  # mid-motion around the cursor: the picture could be either; look again
                    time.sleep(0.7)
                    continue
                image = image_module.open(io.BytesIO(shot)).convert("RGB")
                plot = (780, 90, 1085, 290)  # the "left leg position" plot, top left of the plots
                knee = _rightmost(image, plot, KNEE_GREEN)
                zero = _rightmost(image, plot, HIP_YAW_RED)
                assert knee and zero, "no knee / hip_yaw series in the left-leg plot"
                bent_on_screen = zero[1] - knee[1] > 25  # pixels above the zero line
                checked.append((now - cursor, min(window) > 0.3, bent_on_screen))
                time.sleep(1.3)
        assert checked, "the viewer never showed sim_time data with a settled knee"
        for lag, bent, bent_on_screen in checked:
            assert lag < 1.0, f"the page shows sim time {lag:.1f} s behind the simulation: {checked}"
            assert bent == bent_on_screen, f"knee {'bent' if bent else 'straight'} at the cursor, not on screen"
        for sub in subs:
            sub.undeclare()
    finally:
        if session is not None:
            session.close()
        if launch.poll() is None:
            os.killpg(launch.pid, 2)
        try:
            launch.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, 9)
            launch.wait()
