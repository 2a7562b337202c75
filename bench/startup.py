"""Startup of the main job: time from ``python -m launch humanoid.yaml gui:=false`` to the first
``humanoid/joint_states`` message, and the peak total RSS of the launcher's process tree.

    python bench/startup.py [--runs 5] [--settle 3] [--mode realtime] [--compare humanoid.launch.py]

Prints a table, then (last line) JSON: ``first_joint_states_s`` (median), ``peak_rss_mb`` (median of the
per-run peaks), and the per-run values. Goal: < 3 s to the first joint_states.

``--compare FILE`` also starts FILE (the same job in another launch format: humanoid.launch.py is humanoid.yaml
written with the ROS launch API), alternating with humanoid.yaml run by run so both see the same machine load;
the JSON then has ``compare`` (FILE's figures) and ``difference_s`` (FILE's median minus humanoid.yaml's;
goal: within +0.5 s).
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.common import Launch, plain_peer  # noqa: E402 - after the path is set (bench scripts run from anywhere)


def tree_rss(root: psutil.Process) -> int:
    total = 0
    try:
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0
    for proc in procs:
        try:
            total += proc.memory_info().rss
        except psutil.Error:
            pass
    return total


def listening(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(0.05)
        return s.connect_ex(("127.0.0.1", port)) == 0


def one_run(mode: str, settle_s: float, timeout_s: float, launch_file: str = "humanoid.yaml") -> tuple[float, float]:
    first = threading.Event()
    with tempfile.TemporaryDirectory() as logs:
        start = time.monotonic()
        launch = Launch(launch_file, f"mode:={mode}", log_dir=Path(logs))
        root = psutil.Process(launch.proc.pid)
        peak = 0
        first_at = None
        session = None
        try:
            while time.monotonic() - start < timeout_s:
                peak = max(peak, tree_rss(root))
                if session is None and listening(launch.port):
                    session = plain_peer(launch.port)
                    launch.sessions.append(session)
                    session.declare_subscriber("humanoid/joint_states", lambda _s: first.set())
                if first_at is None and first.is_set():
                    first_at = time.monotonic() - start
                if first_at is not None and time.monotonic() - start > first_at + settle_s:
                    break
                launch.check()
                time.sleep(0.02)
            if first_at is None:
                raise RuntimeError(f"no humanoid/joint_states within {timeout_s:g} s")
        finally:
            launch.close()
    return first_at, peak / 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--settle", type=float, default=3.0, help="seconds to keep sampling RSS after the first "
                        "joint_states")
    parser.add_argument("--mode", default="realtime", choices=["realtime", "lockstep"])
    parser.add_argument("--timeout", type=float, default=60.0)
    parser.add_argument("--compare", default=None, metavar="FILE",
                        help="also time FILE (e.g. humanoid.launch.py), alternating with humanoid.yaml")
    args = parser.parse_args()
    files = ["humanoid.yaml", *([args.compare] if args.compare else [])]
    times: dict[str, list[float]] = {f: [] for f in files}
    peaks: dict[str, list[float]] = {f: [] for f in files}
    print(f"{'run':>3}  {'file':<20}  {'first joint_states (s)':>22}  {'peak tree RSS (MB)':>18}")
    for run in range(1, args.runs + 1):
        for launch_file in files if run % 2 else reversed(files):   # alternate which one goes first
            first_at, peak_mb = one_run(args.mode, args.settle, args.timeout, launch_file)
            times[launch_file].append(first_at)
            peaks[launch_file].append(peak_mb)
            print(f"{run:>3}  {launch_file:<20}  {first_at:>22.3f}  {peak_mb:>18.1f}", flush=True)
    summary = {}
    for launch_file in files:
        median_time, median_peak = statistics.median(times[launch_file]), statistics.median(peaks[launch_file])
        print(f"med  {launch_file:<20}  {median_time:>22.3f}  {median_peak:>18.1f}   (goal: < 3 s to first "
              f"joint_states; {os.cpu_count()} cores, mode {args.mode})")
        summary[launch_file] = {"first_joint_states_s": round(median_time, 3), "peak_rss_mb": round(median_peak, 1),
                                "per_run_s": [round(t, 3) for t in times[launch_file]],
                                "per_run_rss_mb": [round(p, 1) for p in peaks[launch_file]]}
    result = {**summary["humanoid.yaml"], "runs": args.runs, "mode": args.mode}
    if args.compare:
        result["compare"] = {"file": args.compare, **summary[args.compare]}
        result["difference_s"] = round(summary[args.compare]["first_joint_states_s"]
                                       - summary["humanoid.yaml"]["first_joint_states_s"], 3)
        print(f"{args.compare} - humanoid.yaml: {result['difference_s']:+.3f} s (goal: within +0.5 s)")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
