"""The viewer's lag as a person sees it, and the visualiser's own cost.

    python bench/viz.py [--mode browser|node] [--seconds 60] [--open-after 20] [--repeat 3]
                        [--renderer llvmpipe|swiftshader] [--viewer-args "..."] [--trace] [--catch-up 180]
    python bench/viz.py --mode node [--source humanoid|feeder] [--seconds 10] [--repeat 3]

``browser`` (default): the main job (``launch/humanoid.yaml``, realtime, its viewer served as a web page) and a
real headless Chromium (software rendering: Mesa llvmpipe, or SwiftShader) that opens the page ``--open-after``
seconds into the run (a late viewer) and is read over the remote-debugging protocol (``tests.support.browser``):
every second, the viewer's time cursor on ``sim_time`` (what its views show) against the simulator's
``sim/clock`` at that instant. A late viewer first takes in what the server kept (the layout and the newest
rows), so the page's start is measured apart from its steady state: ``viewer_ready_s`` (page opened -> the
viewer running), ``first_view_s`` (-> first data shown) and ``first_view_lag_s`` (how far from the present it
starts), ``live_after_s`` (-> first within 1 s of the simulation: the time to the present; ``null``: not within
``--catch-up`` s) and ``startup_frames_per_s`` (frames the page drew until then). The ``--seconds`` window
starts then: ``lag_p50_s``, ``lag_p95_s``, ``lag_max_s``, ``lag_last_s`` (sim s the page is behind the
simulation), ``frames_per_s`` and ``chromium_cpu_percent`` (of one core); and ``load_avg_1min``. Each of
``--repeat`` runs starts its own main job; prints a table (each run and the median) and one JSON line of
medians (``--trace``: also each run's lag every second since the page opened). Goals: the present within
10 s of opening the page, then lag <= 1 s for the whole run.

``humanoid`` (default): the main job (``launch/humanoid.yaml``, realtime, 1 kHz controller manager,
joint_states at 100 Hz, the joint commander) plus the visualiser saving an .rrd. Its stamps are sim time
(which slips behind the wall clock on a loaded machine), so a probe node in this process records when each
stamp arrives; the lag of a sample is its Rerun ``log_time`` minus that arrival (the visualiser's own
delay; the Zenoh hop adds ~0.2 ms, FACTS). ``feeder``: ``tests.support.viz_feeder`` stamps joint_states with the
wall clock at 100 Hz, so the lag from stamp to logging is exact.

Prints a table, then one JSON line: ``cpu_percent`` (of one core, over the window), ``lag_p50_ms``,
``lag_p99_ms``, ``lag_max_ms``, ``joint_states_hz``: medians of ``--repeat`` runs (default 3; the machine is
shared, so single runs vary). Goals: < 25 % of a core, p99 < 50 ms.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import Launch, child_env, free_port, spawn, stop_all, wait_until  # noqa: E402
from nodes.core.delivery import Inline  # noqa: E402
from tests.support.rrd import load  # noqa: E402


def lags_ms(rows: list[dict], arrivals: dict[int, float] | None) -> np.ndarray:
    """Stamp (feeder: wall clock, on the visualiser's wall_time timeline) or probe arrival time -> Rerun
    log_time, in ms."""
    if arrivals is None:
        return np.array([r["log_time"] - r["wall_time"] for r in rows]) * 1e3
    return np.array([r["log_time"] - arrivals[round(r["sim_time"] * 1e6)] for r in rows
                     if round(r["sim_time"] * 1e6) in arrivals]) * 1e3


def start_probe(port: int):
    """A node in this process noting the wall time each joint_states stamp arrives (humanoid source)."""
    import msgs
    from nodes.core import Node

    arrivals: dict[int, float] = {}
    node = Node("bench_viz_probe", connect=[f"tcp/127.0.0.1:{port}"])

    def on_state(msg) -> None:
        arrivals[round((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9) * 1e6)] = time.time()

    node.create_subscription(msgs.get_type("sensor_msgs/msg/JointState"), "/humanoid/joint_states", on_state,
                             delivery=Inline())
    return node, arrivals


def run_once(source: str, seconds: float, port: int) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bench_viz_"))

    def start(name: str, *argv: str) -> tuple[subprocess.Popen, Path]:
        log = work / f"{name}.log"
        proc = spawn([sys.executable, *argv], log=log)
        procs.append(proc)
        return proc, log

    procs: list[subprocess.Popen] = []
    probe, arrivals = None, None
    try:
        if source == "humanoid":
            launch = Launch("humanoid.yaml", "mode:=realtime", log_dir=work, port=port)
            procs.append(launch.proc)
            launch.wait_output("started 'joint_commander'", 90)
            probe, arrivals = start_probe(port)
        else:
            start("router", "-c", "import time\nfrom nodes.core.session import open_router\n"
                  f"s = open_router({port})\ntime.sleep(3600)")
            time.sleep(1.0)
            start("state_publisher", "-m", "nodes.state_publisher", "--ns", "humanoid", "--zenoh-port",
                  str(port), "--param", f"robot_description_file:={ROOT / 'robots' / 'humanoid.urdf'}")
            start("feeder", "-m", "tests.support.viz_feeder", "--param", "stamp:=wall", "--zenoh-port", str(port))
        rrd = work / "bench.rrd"
        viz, viz_log = start("viz", "-m", "nodes.viz", "--save", str(rrd), "--robots", "humanoid",
                             "--zenoh-port", str(port))
        wait_until(lambda: "23 visuals" in viz_log.read_text(errors="replace"), 60, "23 visuals in the visualiser")
        time.sleep(3.0)  # settle: discovery, first blueprint, caches
        process = psutil.Process(viz.pid)
        cpu_before, wall_before = process.cpu_times(), time.monotonic()
        time.sleep(seconds)
        cpu_after, wall_after = process.cpu_times(), time.monotonic()
        window = (time.time() - seconds, time.time())
        stop_all([viz])
        cpu = (cpu_after.user + cpu_after.system) - (cpu_before.user + cpu_before.system)
        rows = [r for r in load(rrd)["world/humanoid/robot"].rows if r.get("position:left_leg") is not None
                and "log_time" in r and window[0] <= r["log_time"] <= window[1]]
        if len(rows) < 10:
            raise SystemExit(f"only {len(rows)} joint_states rows logged in the window; logs in {work}")
        lag = lags_ms(rows, arrivals)
    finally:
        if probe is not None:
            probe.destroy()
        stop_all(procs[::-1])
    return {"cpu_percent": 100.0 * cpu / (wall_after - wall_before),
            "lag_p50_ms": float(np.percentile(lag, 50)), "lag_p99_ms": float(np.percentile(lag, 99)),
            "lag_max_ms": float(lag.max()), "joint_states_hz": len(rows) / seconds,
            "load_avg_1min": os.getloadavg()[0]}


def run_browser(seconds: float, open_after: float, port: int, renderer: str, viewer_args: str = "",
                catch_up: float = 180.0) -> dict:
    """The main job with its served viewer, and a headless Chromium reading the page (see the docstring)."""
    from tests.support.browser import HeadlessBrowser, ViewerProbe

    work = Path(tempfile.mkdtemp(prefix="bench_viz_browser_"))
    env = {k: v for k, v in child_env().items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    launch = Launch("humanoid.yaml", "mode:=realtime", "viewer_args:=--serve --web-port 0 --grpc-port 0 " + viewer_args,
                    log_dir=work, port=port, gui=True, env=env)
    probe = None
    try:
        url = launch.wait_match(r"Rerun web viewer: (\S+)", 90).group(1)
        import msgs
        from nodes.core import Node

        sim = {"now": 0.0}
        probe = Node("bench_viz_clock", connect=[f"tcp/127.0.0.1:{port}"])
        probe.create_subscription(msgs.get_type("rosgraph_msgs/msg/Clock"), "/sim/clock",
                                  lambda m: sim.__setitem__("now", m.clock.sec + m.clock.nanosec * 1e-9),
                                  delivery=Inline())
        launch.wait_output("started 'joint_commander'", 90)
        time.sleep(open_after)
        with HeadlessBrowser(timeout=120, renderer=renderer) as browser:
            opened = time.monotonic()
            page = ViewerProbe(browser, url)
            page.wait_ready(120)
            ready = time.monotonic() - opened
            browser.evaluate("window.__frames = 0; (function f() { window.__frames++; requestAnimationFrame(f); })(); 1")
            tree = psutil.Process(browser.proc.pid)

            def chromium_cpu() -> float:
                total = 0.0
                for proc in [tree, *tree.children(recursive=True)]:
                    try:
                        times = proc.cpu_times()
                        total += times.user + times.system
                    except psutil.Error:
                        pass
                return total

            first_view = first_lag = live = startup_fps = None
            window = False
            lags: list[float] = []
            trace: list[tuple[float, float]] = []  # (s since the page opened, lag)
            frames0, cpu0, wall0 = 0, chromium_cpu(), time.monotonic()
            # The window of `seconds` starts when the page first shows the present (lag < 1 s); until then (a
            # late viewer taking in the server's history) it waits at most `catch_up` s, then measures anyway.
            deadline = opened + catch_up + seconds
            while time.monotonic() < deadline:
                recording = page.recording()
                now = sim["now"]  # read right after the page answered: the lag is never underestimated
                if recording is not None and recording.cursor_timeline == "sim_time" and recording.cursor_ns:
                    lag = now - recording.cursor_ns * 1e-9
                    trace.append((round(time.monotonic() - opened, 1), round(lag, 2)))
                    if first_view is None:
                        first_view, first_lag = time.monotonic() - opened, lag
                    if not window and (lag < 1.0 or time.monotonic() > opened + catch_up):
                        window = True
                        live = time.monotonic() - opened if lag < 1.0 else None
                        frames0 = browser.evaluate("window.__frames") or 0
                        startup_fps = frames0 / max(time.monotonic() - opened - ready, 1e-9)
                        cpu0, wall0, deadline = chromium_cpu(), time.monotonic(), time.monotonic() + seconds
                    if window:
                        lags.append(lag)
                time.sleep(1.0)
            frames = (browser.evaluate("window.__frames") or 0) - frames0
            cpu1, wall1 = chromium_cpu(), time.monotonic()
            shot = work / "viewer.png"
            browser.screenshot(shot)
    finally:
        if probe is not None:
            probe.destroy()
        launch.close(30)
    if not lags:
        raise SystemExit(f"the page never showed sim_time data; logs in {work}")
    array = np.array(lags)
    return {"lag_p50_s": float(np.percentile(array, 50)), "lag_p95_s": float(np.percentile(array, 95)),
            "lag_max_s": float(array.max()), "lag_last_s": float(array[-1]), "first_view_s": first_view,
            "first_view_lag_s": first_lag, "viewer_ready_s": ready, "live_after_s": live,
            "frames_per_s": frames / max(wall1 - wall0, 1e-9), "startup_frames_per_s": startup_fps,
            "chromium_cpu_percent": 100.0 * (cpu1 - cpu0) / max(wall1 - wall0, 1e-9),
            "load_avg_1min": os.getloadavg()[0], "screenshot": str(shot), "trace": trace}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mode", choices=("browser", "node"), default="browser")
    parser.add_argument("--source", choices=("humanoid", "feeder"), default="humanoid", help="node mode's source")
    parser.add_argument("--seconds", type=float, default=None,
                        help="measurement window (browser: 60 s after the first view; node: 10 s per run)")
    parser.add_argument("--repeat", type=int, default=3, help="runs; the JSON line has the medians")
    parser.add_argument("--open-after", type=float, default=20.0, help="browser mode: s of run before the page opens")
    parser.add_argument("--renderer", choices=("llvmpipe", "swiftshader"), default="llvmpipe")
    parser.add_argument("--zenoh-port", type=int, default=0)
    parser.add_argument("--trace", action="store_true", help="browser mode: print the lag every second")
    parser.add_argument("--catch-up", type=float, default=180.0,
                        help="browser mode: s the page gets to reach the present before the window starts anyway")
    parser.add_argument("--viewer-args", default="",
                        help="browser mode: extra visualiser options, e.g. \"--param flush_period:=1.0\"")
    args = parser.parse_args()
    if args.mode == "browser":
        runs = [run_browser(args.seconds or 60.0, args.open_after, args.zenoh_port or free_port(), args.renderer,
                            args.viewer_args, args.catch_up) for _ in range(args.repeat)]
        metrics = [m for m in runs[0] if m not in ("screenshot", "trace")]
        print(f"{'metric':<24}" + "".join(f"{'run ' + str(i + 1):>10}" for i in range(len(runs)))
              + f"{'median':>10}{'goal':>8}")
        result: dict = {"mode": "browser", "renderer": args.renderer, "open_after_s": args.open_after,
                        "seconds": args.seconds or 60.0, "runs": len(runs), "viewer_args": args.viewer_args}
        goals = {"live_after_s": "<= 10", "lag_max_s": "<= 1"}
        for metric in metrics:
            # A page that never reached the present counts as slower than any that did.
            values = [math.inf if run[metric] is None else float(run[metric]) for run in runs]
            median = float(np.median(values))
            result[metric] = None if math.isinf(median) else round(median, 2)
            print(f"{metric:<24}" + "".join(f"{'never' if math.isinf(v) else f'{v:.2f}':>10}" for v in values)
                  + f"{'never' if math.isinf(median) else f'{median:.2f}':>10}{goals.get(metric, ''):>8}")
        if args.trace:
            for i, run in enumerate(runs):
                print(f"run {i + 1}: page opened + s -> lag s: "
                      + ", ".join(f"{t:g}:{lag:g}" for t, lag in run["trace"]))
        result["screenshots"] = [run["screenshot"] for run in runs]
        print(json.dumps(result))
        return 0
    args.seconds = args.seconds or 10.0
    runs = [run_once(args.source, args.seconds, args.zenoh_port or free_port()) for _ in range(args.repeat)]
    metrics = list(runs[0])
    print(f"{'metric':<24}" + "".join(f"{'run ' + str(i + 1):>10}" for i in range(len(runs)))
          + f"{'median':>10}{'goal':>8}")
    goals = {"cpu_percent": "< 25", "lag_p99_ms": "< 50"}
    result: dict = {"source": args.source, "seconds": args.seconds, "runs": len(runs)}
    for metric in metrics:
        values = [run[metric] for run in runs]
        result[metric] = round(float(np.median(values)), 2)
        print(f"{metric:<24}" + "".join(f"{v:>10.2f}" for v in values) + f"{result[metric]:>10.2f}"
              + f"{goals.get(metric, ''):>8}")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
