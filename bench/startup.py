"""Startup of the main job: time from ``python -m launch humanoid.yaml gui:=false`` to the first
``humanoid/joint_states`` message, and the peak total RSS of the launcher's process tree.

    python bench/startup.py [--runs 5] [--settle 3] [--mode realtime]

Prints a table, then (last line) JSON: ``first_joint_states_s`` (median), ``peak_rss_mb`` (median of the
per-run peaks), and the per-run values. Goal: < 3 s to the first joint_states.
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


def one_run(mode: str, settle_s: float, timeout_s: float) -> tuple[float, float]:
    first = threading.Event()
    with tempfile.TemporaryDirectory() as logs:
        start = time.monotonic()
        launch = Launch("humanoid.yaml", f"mode:={mode}", log_dir=Path(logs))
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
    args = parser.parse_args()
    times, peaks = [], []
    print(f"{'run':>3}  {'first joint_states (s)':>22}  {'peak tree RSS (MB)':>18}")
    for run in range(1, args.runs + 1):
        first_at, peak_mb = one_run(args.mode, args.settle, args.timeout)
        times.append(first_at)
        peaks.append(peak_mb)
        print(f"{run:>3}  {first_at:>22.3f}  {peak_mb:>18.1f}", flush=True)
    median_time, median_peak = statistics.median(times), statistics.median(peaks)
    print(f"med  {median_time:>22.3f}  {median_peak:>18.1f}   (goal: < 3 s to first joint_states; "
          f"{os.cpu_count()} cores, mode {args.mode})")
    print(json.dumps({"first_joint_states_s": round(median_time, 3), "peak_rss_mb": round(median_peak, 1),
                      "runs": args.runs, "mode": args.mode, "per_run_s": [round(t, 3) for t in times],
                      "per_run_rss_mb": [round(p, 1) for p in peaks]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
