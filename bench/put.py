"""What one Zenoh put costs the calling thread, by how closely puts follow each other.

A peer session in this process publishes a 900-byte payload (a 22-joint JointState's size) with a 24-byte
attachment (our publishers' sequence number and source id) to a subscriber in another process, over loopback
TCP. Each put is timed on the calling thread (``perf_counter_ns``), with ``--gap`` µs of sleep between puts
(the lockstep main job publishes every ~150-200 µs) and with none (a burst, which Zenoh batches), for
``express`` off and on. What the caller pays beyond the hand-over into Zenoh's queue is the wake-up of its
transmission thread, which then writes the socket.

    python bench/put.py [--puts 8000] [--gap 150]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import free_port, loopback, print_table, stop  # noqa: E402 - after the path is set

KEY = "bench/put"
PAYLOAD = bytes(900)
ATTACHMENT = bytes(24)
SUBSCRIBER = r"""
import json, sys, time, zenoh
conf = zenoh.Config()
conf.insert_json5("mode", '"peer"')
conf.insert_json5("connect/endpoints", json.dumps([sys.argv[1]]))
conf.insert_json5("scouting/multicast/enabled", "false")
with zenoh.open(conf) as session:
    count = [0]
    session.declare_subscriber(sys.argv[2], lambda sample: count.__setitem__(0, count[0] + 1))
    print("ready", flush=True)
    sys.stdin.read()        # until the bench closes our stdin
    time.sleep(0.5)         # the last puts still on their way
    print(count[0], flush=True)
"""


def timed_puts(publisher, count: int, gap_s: float) -> list[float]:
    """Call times of ``count`` puts, in µs, sorted."""
    times = []
    for _ in range(count):
        started = time.perf_counter_ns()
        publisher.put(PAYLOAD, attachment=ATTACHMENT)
        times.append((time.perf_counter_ns() - started) / 1e3)
        if gap_s:
            time.sleep(gap_s)
    return sorted(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--puts", type=int, default=8000, help="puts per case")
    parser.add_argument("--gap", type=float, default=150.0, help="µs between the spaced puts")
    args = parser.parse_args(argv)
    import zenoh

    port = free_port()
    load_before = os.getloadavg()[0]
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([loopback(port)]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    subscriber = subprocess.Popen([sys.executable, "-c", SUBSCRIBER, loopback(port), KEY], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True, start_new_session=True)
    rows, results = [], {}
    try:
        if subscriber.stdout.readline().strip() != "ready":
            raise SystemExit("the subscriber did not start")
        time.sleep(1.0)   # its declaration reaches this session
        for express in (False, True):
            publisher = session.declare_publisher(KEY, express=express)
            for gap_us in (args.gap, 0.0):
                times = timed_puts(publisher, args.puts, gap_us / 1e6)
                n = len(times)
                spacing = f"every {gap_us:g} µs" if gap_us else "burst"
                case = f"express={'on' if express else 'off'}, {spacing}"
                figures = {"p50": times[n // 2], "p75": times[n * 3 // 4], "p90": times[n * 9 // 10],
                           "p99": times[n * 99 // 100], "mean": sum(times) / n}
                results[case] = {k: round(v, 2) for k, v in figures.items()}
                rows.append((case, f"{figures['mean']:.1f} µs", "mean; p50 / p75 / p90 / p99 "
                             f"{figures['p50']:.1f} / {figures['p75']:.1f} / {figures['p90']:.1f} / "
                             f"{figures['p99']:.1f} µs"))
            publisher.undeclare()
        subscriber.stdin.close()
        received = int(subscriber.stdout.readline().strip() or 0)
        subscriber.wait(timeout=10)
    finally:
        if subscriber.poll() is None:
            stop(subscriber, timeout=5)
        session.close()
    rows.append(("messages received by the subscriber", f"{received:,}", f"of {4 * args.puts:,} put"))
    print_table(rows, load_before)
    print(json.dumps({"puts": args.puts, "gap_us": args.gap, "received": received, "cases": results,
                      "load_average": load_before}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
