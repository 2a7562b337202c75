"""The served web viewer loads in headless Chromium and draws something (regenerates nothing in docs/)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import wait_until
from tests.support.screenshot import find_browser

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
@pytest.mark.skipif(find_browser() is None, reason="no Chromium installed (Debian: apt-get install chromium)")
def test_served_web_viewer_renders_in_headless_chromium(tmp_path: Path) -> None:
    out = tmp_path / "viz.png"
    result = subprocess.run([sys.executable, "-m", "tests.support.screenshot", "--out", str(out), "--settle", "3",
                             "--render", "15"], cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout + result.stderr
    image = pytest.importorskip("PIL.Image").open(out).convert("RGB")
    assert image.size == (1400, 800)
    left = image.crop((0, 40, 770, 770)).getcolors(maxcolors=1 << 20)  # the 3-D view
    # The ground: the viewer's own 0.5 m grid (grey lines, from the layout), across the view: the scene was drawn.
    grid = sum(n for n, (r, g, b) in left if 120 <= r <= 200 and 0 <= g - r <= 10 and 0 <= b - r <= 16)
    assert grid > 10_000, f"no ground grid in the 3-D view ({grid} grey pixels): viewer not drawn"
    # The robot's torso blue (URDF material 'blue', shaded) is somewhere in the 3-D view on the left.
    bluish = sum(n for n, (r, g, b) in left if b > 120 and b > r + 60 and b > g + 30)
    assert bluish > 2000, f"no robot torso in the 3-D view ({bluish} blue pixels)"


# -- the main job's viewer, live ------------------------------------------------------------------------
KNEE_GREEN = (90, 200, 120)  # PALETTE[3]: the knee, 4th joint of the "left leg" plot
# PALETTE[0, 1, 5]: left hip_yaw, hip_roll and ankle_roll, which stay at 0 in the knee bend (whichever is drawn
# last covers the others)
ZERO_SERIES = ((230, 85, 70), (80, 160, 240), (60, 210, 210))


def _rightmost(image, box: tuple[int, int, int, int], *colors: tuple[int, int, int]) -> tuple[int, int] | None:
    """(x, y) of the rightmost pixel of any of ``colors`` (±30 per channel) inside ``box``."""
    left, top, right, bottom = box
    pixels = image.load()
    for x in range(right - 1, left - 1, -1):
        ys = [y for y in range(top, bottom)
              if any(all(abs(c - w) <= 30 for c, w in zip(pixels[x, y], rgb)) for rgb in colors)]
        if ys:
            return x, sum(ys) // len(ys)
    return None


@pytest.mark.slow
@pytest.mark.alone   # a software-rendered page catching up with a realtime job: CPU-bound, as a user's is not
@pytest.mark.timeout(480)   # its own deadline is 420 s (a page opened anew per try); the suite's 300 s cut it short
@pytest.mark.skipif(find_browser() is None, reason="no Chromium installed (Debian: apt-get install chromium)")
def test_main_job_viewer_shows_the_present_pose(tmp_path: Path, zenoh_port: int) -> None:
    """A page opened 10 s into the main job (its viewer with the default settings) reaches the simulation's
    present, and then what it draws is the present: paused while its time cursor is within 1 s of the
    simulation, the knee in the picture (the left-leg plot at the cursor) is bent or straight as joint_states
    had it at the cursor. A try whose cursor lands while the knee moves opens the page anew.

    How fast it gets there is the bench's business (``bench/viz.py``); the deadline here only bounds a page
    that never catches up, with room for a loaded machine."""
    import io
    import math
    import threading
    import time

    import msgpack

    from bench.common import Launch, child_env
    from tests.support.browser import HeadlessBrowser, ViewerProbe

    image_module = pytest.importorskip("PIL.Image")
    env = {k: v for k, v in child_env().items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    launch = Launch("humanoid.yaml", "mode:=realtime", "viewer_args:=--serve --web-port 0 --grpc-port 0",
                    log_dir=tmp_path, port=zenoh_port, gui=True, env=env)
    knees: dict[int, float] = {}  # sim time (ms) -> left_knee, from joint_states
    clock = {"now": 0.0}
    lock = threading.Lock()
    try:
        url = launch.wait_match(r"Rerun web viewer: (\S+)", 90).group(1)
        session = launch.peer()

        def on_state(sample) -> None:
            msg = msgpack.unpackb(sample.payload.to_bytes())
            stamp = msg["header"]["stamp"]
            with lock:
                knees[round((stamp["sec"] + stamp["nanosec"] * 1e-9) * 1000)] = msg["position"][
                    msg["name"].index("left_knee")]

        def on_clock(sample) -> None:
            stamp = msgpack.unpackb(sample.payload.to_bytes())["clock"]
            clock["now"] = stamp["sec"] + stamp["nanosec"] * 1e-9

        session.declare_subscriber("humanoid/joint_states", on_state)
        session.declare_subscriber("sim/clock", on_clock)
        # A pose every 4 s, not 2: the knee then rests 3 s of each 4, so a pause lands in a still stretch on
        # most tries (each miss opens the page anew and waits for it to catch up again).
        subprocess.run([sys.executable, "-m", "nodes.tools", "param", "set", "/humanoid/joint_commander", "period",
                        "4.0"], env={**env, "ZENOH_CONNECT": f"tcp/127.0.0.1:{zenoh_port}"}, check=True,
                       capture_output=True, timeout=60)
        time.sleep(10.0)  # the main job runs for a while before anyone looks

        def sim_time(recording) -> float | None:
            if recording is None or recording.cursor_timeline != "sim_time" or not recording.cursor_ns:
                return None
            return recording.cursor_ns * 1e-9

        lags: list[float] = []  # sim s the page was behind, every second
        tries: list[str] = []
        checked: list[tuple[float, bool, bool]] = []  # (lag, knee bent in joint_states, bent on screen)
        deadline = time.monotonic() + 420
        with HeadlessBrowser(timeout=120) as browser:
            # Each try opens the page anew (a late viewer), waits until it shows the present, and then pauses it:
            # the picture is of a known time (the cursor no longer moves), which the knee is compared at.
            while not checked and time.monotonic() < deadline:
                page = ViewerProbe(browser, url)
                page.wait_ready(120)
                lag = math.inf
                while lag >= 1.0 and time.monotonic() < deadline:
                    time.sleep(1.0)
                    cursor = sim_time(page.recording())
                    if cursor is not None:
                        lag = clock["now"] - cursor  # read after the page answered: never underestimated
                        lags.append(round(lag, 2))
                if lag >= 1.0:
                    break
                page.pause()
                frozen, cursor = None, -1.0
                for _ in range(20):  # until the cursor stays put
                    time.sleep(0.5)
                    frozen, cursor = cursor, sim_time(page.recording()) or -1.0
                    if frozen == cursor:
                        break
                assert frozen == cursor > 0, f"the page did not pause (cursor {frozen} then {cursor})"
                # The plot's newest point is the row at the cursor (rows come every 0.1 s), but a paused page
                # still draws the rows that arrive after it a few pixels right of the cursor line: the knee
                # must be in one state from just before the cursor to half a second after it.
                wait_until(lambda at=cursor: clock["now"] > at + 0.6, timeout=30, message="sim time past the cursor")
                with lock:
                    window = [v for t, v in knees.items() if cursor - 0.15 <= t / 1000 <= cursor + 0.5]
                if not window or not (min(window) > 0.3 or max(window) < 0.05):
                    tries.append(f"{cursor:.2f}: knee mid-motion")  # the picture could be either; try again
                    continue
                shot = browser.screenshot(tmp_path / f"check_{len(checked)}.png")
                image = image_module.open(io.BytesIO(shot)).convert("RGB")
                plot = (780, 90, 1085, 290)  # the "left leg position" plot, top left of the plots
                knee = _rightmost(image, plot, KNEE_GREEN)
                zero = _rightmost(image, plot, *ZERO_SERIES)
                assert knee and zero, "no knee / zero-valued series in the left-leg plot"
                assert knee[0] > 950 and zero[0] > 950, f"the newest points are not at the cursor: {knee}, {zero}"
                bent_on_screen = zero[1] - knee[1] > 25  # pixels above the zero line
                checked.append((lag, min(window) > 0.3, bent_on_screen))
                tries.append(f"{cursor:.2f}: checked")
        assert checked, f"the page never showed the present (sim s behind, every second: {lags}; {tries})"
        for lag, bent, bent_on_screen in checked:
            assert bent == bent_on_screen, (f"knee {'bent' if bent else 'straight'} at the cursor ({lag:.2f} s "
                                            f"behind the simulation when paused), not on screen")
    finally:
        launch.close(30)
