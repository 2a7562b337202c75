"""Where the CPU of the lockstep main job goes, thread by thread, per simulated step.

Starts ``python -m launch humanoid.yaml mode:=lockstep gui:=false`` (extra ``NAME:=VALUE`` arguments are
passed on, e.g. ``world:=empty.world sensors:=false``), lets it run ``--warmup`` seconds, then reads every
thread's CPU time (``/proc/PID/task/TID/stat``: user + system) of the launcher and its nodes before and after
``--seconds`` of stepping, and the simulated time from ``sim/clock`` (an outside zenoh + msgpack subscriber).
Each thread's CPU is divided by the steps taken: what one physics step (one control period at 1 kHz) costs
each thread, beside the wall-clock period. Zenoh's runtime threads are named ``rx-N`` (reception), ``tx-N``
(transmission), ``net-N`` and ``acc-N``; Python's own are ``python``.

The launcher gives the simulator's stepping thread a CPU of its own (``exclusive_cpu``): on 2 cores every
other thread shares the other one, so the sum of the other threads' CPU per step against the period says
whether that core is the bottleneck. With ``composed:=true`` the stepping thread is the container's busiest
(it runs the controller manager's cycle too).

    python bench/lockstep_threads.py [--seconds 5] [--warmup 20] [world:=empty.world sensors:=false ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import free_port, loopback, print_table, spawn, stop  # noqa: E402 - after the path is set

TICK = os.sysconf("SC_CLK_TCK")


def descendants(pid: int) -> list[tuple[int, str]]:
    """(pid, the module it runs or its command) of every process below ``pid``."""
    out = subprocess.run(["ps", "-o", "pid=,args=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    found = []
    for line in out.splitlines():
        child, args = line.strip().split(" ", 1)
        words = args.split()
        name = words[words.index("-m") + 1] if "-m" in words[:-1] else words[0]
        found.append((int(child), name))
        found += descendants(int(child))
    return found


def thread_cpu(pid: int) -> dict[tuple[int, str], float]:
    """CPU seconds per thread of ``pid``, keyed by (thread id, thread name)."""
    times = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            comm = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
            fields = Path(f"/proc/{pid}/task/{tid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:   # the thread ended meanwhile
            continue
        times[(int(tid), comm)] = (int(fields[11]) + int(fields[12])) / TICK
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="how long to measure")
    parser.add_argument("--warmup", type=float, default=20.0, help="seconds between the launch and the measurement")
    args, launch_args = parser.parse_known_args(argv)
    import msgpack
    import zenoh

    port = free_port()
    log = Path(os.environ.get("TMPDIR", "/tmp")) / f"lockstep_threads_{port}.log"
    launch = spawn([sys.executable, "-m", "launch", "humanoid.yaml", "mode:=lockstep", "gui:=false",
                    f"zenoh_port:={port}", *launch_args], log=log)
    load_before = os.getloadavg()[0]
    try:
        time.sleep(args.warmup)
        processes = [(launch.pid, "launcher (+router)"), *descendants(launch.pid)]
        config = zenoh.Config()
        config.insert_json5("mode", '"client"')
        config.insert_json5("connect/endpoints", json.dumps([loopback(port)]))
        config.insert_json5("scouting/multicast/enabled", "false")
        latest: list[float] = []
        arrived = threading.Event()

        def on_clock(sample: zenoh.Sample) -> None:
            clock = msgpack.unpackb(sample.payload.to_bytes())["clock"]
            latest[:] = [clock["sec"] + clock["nanosec"] * 1e-9]
            arrived.set()

        with zenoh.open(config) as session:
            session.declare_subscriber("sim/clock", on_clock)
            if not arrived.wait(30):
                raise SystemExit(f"no sim/clock within 30 s (launch log: {log})")
            sim0, wall0 = latest[0], time.perf_counter()
            before = {(pid, name): thread_cpu(pid) for pid, name in processes}
            time.sleep(args.seconds)
            after = {(pid, name): thread_cpu(pid) for pid, name in processes}
            sim1, wall1 = latest[0], time.perf_counter()
    finally:
        stop(launch)
    steps = (sim1 - sim0) * 1000.0   # 1 kHz physics (humanoid.yaml's default)
    if steps <= 0:
        raise SystemExit("sim time did not advance")
    period_us = 1e6 * (wall1 - wall0) / steps
    rows, threads = [], []
    total = 0.0
    for (pid, name), cpu_after in after.items():
        cpu_before = before[(pid, name)]
        for (tid, comm), seconds in sorted(cpu_after.items()):
            spent = seconds - cpu_before.get((tid, comm), 0.0)
            if spent <= 0:
                continue
            per_step = 1e6 * spent / steps
            total += per_step
            threads.append({"process": name, "thread": comm, "tid": tid, "us_per_step": round(per_step, 1)})
            rows.append((f"{name}: {comm} ({tid})", f"{per_step:.1f} µs", "CPU per step"))
    rows.sort(key=lambda row: -float(row[1].split()[0]))
    rows.insert(0, ("period (wall clock per step)", f"{period_us:.0f} µs",
                    f"{steps / (wall1 - wall0):,.0f} steps/s over {args.seconds:g} s"))
    # the simulator's process, or the container it runs in with composed:=true
    stepping = max((t for t in threads if t["process"] in ("nodes.sim", "nodes.core.container")),
                   key=lambda t: t["us_per_step"], default={"us_per_step": 0.0})["us_per_step"]
    rows.append(("the simulator's stepping thread (its process's busiest)", f"{stepping:.0f} µs",
                 f"{100 * stepping / period_us:.0f} % of the period"))
    rows.append(("every other thread", f"{total - stepping:.0f} µs",
                 f"{100 * (total - stepping) / period_us:.0f} % of the period (with exclusive_cpu on 2 cores: one core)"))
    rows.append(("all threads", f"{total:.0f} µs", f"of {2 * period_us:.0f} µs that 2 cores give a period"))
    print_table(rows, load_before)
    print(json.dumps({"steps_per_s": round(steps / (wall1 - wall0), 1), "period_us": round(period_us, 1),
                      "cpu_us_per_step": round(total, 1), "stepping_thread_us_per_step": stepping,
                      "other_threads_us_per_step": round(total - stepping, 1), "threads": threads,
                      "load_average": load_before}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
