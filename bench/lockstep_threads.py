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
whether that core is the bottleneck. The stepping thread is the one pinned to a CPU of its own (the busiest
thread when nothing is pinned); with ``composed:=true`` it is the container's and runs the controller manager's
cycle too.

    python bench/lockstep_threads.py [--seconds 5] [--warmup 20] [world:=empty.world sensors:=false ...]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import free_port, plain_peer, print_table, spawn, stop  # noqa: E402 - after the path is set
from bench.lockstep import process_tree_cpu  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def thread_cpu(pid: int) -> dict[tuple[int, str], tuple[float, bool]]:
    """Per thread of ``pid``, keyed by (thread id, thread name): (CPU seconds, pinned to a single CPU)."""
    times = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            comm = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
            fields = Path(f"/proc/{pid}/task/{tid}/stat").read_text().rsplit(")", 1)[1].split()
            pinned = len(os.sched_getaffinity(int(tid))) == 1
        except OSError:   # the thread ended meanwhile
            continue
        times[(int(tid), comm)] = ((int(fields[11]) + int(fields[12])) / TICK, pinned)
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="how long to measure")
    parser.add_argument("--warmup", type=float, default=20.0, help="seconds between the launch and the measurement")
    args, launch_args = parser.parse_known_args(argv)
    import msgpack

    port = free_port()
    log = Path(os.environ.get("TMPDIR", "/tmp")) / f"lockstep_threads_{port}.log"
    launch = spawn([sys.executable, "-m", "launch", "humanoid.yaml", "mode:=lockstep", "gui:=false",
                    f"zenoh_port:={port}", *launch_args], log=log)
    load_before = os.getloadavg()[0]
    try:
        time.sleep(args.warmup)
        processes = {pid: label for pid, (label, _) in process_tree_cpu(launch.pid).items()}
        latest: list[float] = []
        arrived = threading.Event()

        def on_clock(sample) -> None:
            clock = msgpack.unpackb(sample.payload.to_bytes())["clock"]
            latest[:] = [clock["sec"] + clock["nanosec"] * 1e-9]
            arrived.set()

        with plain_peer(port) as session:
            session.declare_subscriber("sim/clock", on_clock)
            if not arrived.wait(30):
                raise SystemExit(f"no sim/clock within 30 s (launch log: {log})")
            sim0, wall0 = latest[0], time.perf_counter()
            before = {pid: thread_cpu(pid) for pid in processes}
            time.sleep(args.seconds)
            after = {pid: thread_cpu(pid) for pid in processes}
            sim1, wall1 = latest[0], time.perf_counter()
    finally:
        stop(launch)
    steps = (sim1 - sim0) * 1000.0   # 1 kHz physics (humanoid.yaml's default)
    if steps <= 0:
        raise SystemExit("sim time did not advance")
    period_us = 1e6 * (wall1 - wall0) / steps
    threads = []
    for pid, cpu_after in after.items():
        for (tid, comm), (seconds, pinned) in cpu_after.items():
            spent = seconds - before[pid].get((tid, comm), (0.0, False))[0]
            if spent > 0:
                threads.append({"process": processes[pid], "thread": comm, "tid": tid, "pinned": pinned,
                                "us_per_step": round(1e6 * spent / steps, 1)})
    threads.sort(key=lambda t: -t["us_per_step"])
    total = sum(t["us_per_step"] for t in threads)
    # the stepping thread: the one the launcher pinned to a CPU of its own (exclusive_cpu), else the busiest
    stepping = next((t for t in threads if t["pinned"]), threads[0] if threads else {"us_per_step": 0.0})
    rows = [("period (wall clock per step)", f"{period_us:.0f} µs",
             f"{steps / (wall1 - wall0):,.0f} steps/s over {args.seconds:g} s")]
    rows += [(f"{t['process']}: {t['thread']} ({t['tid']})", f"{t['us_per_step']:.1f} µs", "CPU per step")
             for t in threads]
    busy = stepping["us_per_step"]
    rows.append(("the simulator's stepping thread" + ("" if stepping.get("pinned") else " (the busiest; none pinned)"),
                 f"{busy:.0f} µs", f"{100 * busy / period_us:.0f} % of the period"))
    rows.append(("every other thread", f"{total - busy:.0f} µs",
                 f"{100 * (total - busy) / period_us:.0f} % of the period (with exclusive_cpu on 2 cores: one core)"))
    rows.append(("all threads", f"{total:.0f} µs", f"of {2 * period_us:.0f} µs that 2 cores give a period"))
    print_table(rows, load_before)
    print(json.dumps({"steps_per_s": round(steps / (wall1 - wall0), 1), "period_us": round(period_us, 1),
                      "cpu_us_per_step": round(total, 1), "stepping_thread_us_per_step": busy,
                      "other_threads_us_per_step": round(total - busy, 1), "threads": threads,
                      "load_average": load_before}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
