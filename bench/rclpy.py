"""rclpy on zenroid against a nodes.core pair and raw zenoh-python, measured in the same run, interleaved:
a 30-joint JointState published at 1 kHz by this process and received by a subscriber process, which
reports the one-way latency of every message and its own CPU time while receiving (process CPU time over the
wall time from its first message to its last, so start-up is not counted).

- raw: zenoh-python put of a msgpack map -> a zenoh-python callback that unpacks it;
- core: ``nodes.core.Node`` publisher -> ``nodes.core.Node`` subscription, its callback run by ``spin``;
- rclpy: ``rclpy`` publisher -> an ``rclpy`` subscription in a node spun by ``rclpy.spin`` (the callback on
  the spinning thread, as rclpy runs it).

The subscriber also reports its system (kernel) CPU time and its context switches per message (all its
threads): what a thread hand-off per message costs shows there, not in user-space instruction counts. A
subscriber that misses messages (a KEEP_LAST depth of 10 drops the oldest of a burst its spinning thread
could not keep up with) ends 2 s after the last one arrived and reports what it got.

Prints a table, then one JSON line (medians over the runs; goal: rclpy within 1.2x of core on both).

    python bench/rclpy.py [--rate 1000] [--seconds 3] [--runs 3] [--modes raw,core,rclpy]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import child_env, interleaved_runs  # noqa: E402 - after the path is set (bench scripts run from anywhere)
from bench.transport import JOINTS, paced, pacing_arguments  # noqa: E402

MODES = ("raw", "core", "rclpy")
TOPIC = "bench/rclpy_joint_states"


# ------------------------------------------------------------------ subscriber side (child process)

def subscriber(mode: str, endpoint: str, count: int, ready_key: str) -> None:
    import threading

    import msgpack

    os.environ["ZENOH_CONNECT"] = endpoint
    latencies: list[int] = []
    seqs: set[int] = set()
    done = threading.Event()
    window: list[float] = []   # wall and CPU time at the first and at the last message
    marks: list[Any] = []      # resource usage (system time, context switches) at the first and the last

    def usage() -> Any:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF)

    def record(sec: int, nanosec: int, seq: int) -> None:
        now = time.perf_counter_ns()
        last[0] = now
        latencies.append(now - (sec * 1_000_000_000 + nanosec))
        if not window:
            window.extend((time.perf_counter(), time.process_time()))
            marks.append(usage())
        seqs.add(seq)
        if len(seqs) >= count and not done.is_set():
            window.extend((time.perf_counter(), time.process_time()))
            marks.append(usage())
            done.set()

    last = [0]

    def watch() -> None:
        """Messages lost: end the run 2 s after the last one arrived, reporting what did."""
        while not done.wait(0.5):
            if last[0] and time.perf_counter_ns() - last[0] > 2e9 and not done.is_set():
                window.extend((last[0] / 1e9, time.process_time()))
                marks.append(usage())
                done.set()
                if mode == "rclpy":
                    import rclpy

                    rclpy.try_shutdown()

    threading.Thread(target=watch, daemon=True).start()

    if mode == "raw":
        from nodes.core.session import open_peer

        session = open_peer([endpoint])

        def on_raw(sample) -> None:
            m = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
            st = m["header"]["stamp"]
            record(st["sec"], st["nanosec"], int(m["header"]["frame_id"]))

        sub = session.declare_subscriber(TOPIC, on_raw)
        session.put(ready_key, b"1")
        done.wait(60)
        sub.undeclare()
        session.close()
    elif mode == "core":
        import msgs
        from nodes.core import Node

        JointState = msgs.get_type("sensor_msgs/msg/JointState")
        node = Node("bench_sub", connect=[endpoint], log_level="warn")

        def on_msg(msg) -> None:
            record(msg.header.stamp.sec, msg.header.stamp.nanosec, int(msg.header.frame_id))

        node.create_subscription(JointState, "/" + TOPIC, on_msg)
        node.session.put(ready_key, b"1")
        while not done.is_set() and node.ok:
            node.spin_once(0.05)
        node.destroy()
    else:
        import msgs
        import rclpy
        from rclpy.node import Node as RclpyNode

        JointState = msgs.get_type("sensor_msgs/msg/JointState")
        rclpy.init(args=["bench", "--ros-args", "--log-level", "warn"])
        node = RclpyNode("bench_sub")

        def on_ros(msg) -> None:
            record(msg.header.stamp.sec, msg.header.stamp.nanosec, int(msg.header.frame_id))
            if done.is_set():
                rclpy.try_shutdown()

        node.create_subscription(JointState, "/" + TOPIC, on_ros, 10)
        node._zr.session.put(ready_key, b"1")
        try:
            rclpy.spin(node)
        except Exception:  # noqa: BLE001 - the context ended by the last message (ExternalShutdownException)
            pass
        node.destroy_node()
        rclpy.try_shutdown()
    cpu = (window[3] - window[1]) / (window[2] - window[0]) if len(window) == 4 and window[2] > window[0] else None
    extra = {}
    if len(marks) == 2 and len(seqs) > 1:
        start, end = marks
        extra = {"sys": (end.ru_stime - start.ru_stime) / (window[2] - window[0]),
                 "switches": (end.ru_nvcsw + end.ru_nivcsw - start.ru_nvcsw - start.ru_nivcsw) / (len(seqs) - 1)}
    print(json.dumps({"latencies_ns": latencies, "received": len(seqs), "cpu": cpu, **extra}), flush=True)


# ------------------------------------------------------------------ publisher side (this process)

def run_once(mode: str, endpoint: str, rate: float, seconds: float) -> dict:
    import msgpack

    import msgs
    from nodes.core import Node
    from nodes.core.session import open_peer

    count = int(rate * seconds)
    ready_key = f"bench/ready/{mode}/{os.getpid()}/{time.monotonic_ns()}"
    session = open_peer([endpoint])
    ready = []
    ready_sub = session.declare_subscriber(ready_key, lambda s: ready.append(1))
    # child_env: this checkout first on the child's path from its start (an import before this script's own
    # sys.path line may already pull in the installed tree's ``nodes``)
    child = subprocess.Popen([sys.executable, __file__, "--child", mode, endpoint, str(count), ready_key],
                             stdout=subprocess.PIPE, text=True, cwd=ROOT, env=child_env())
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    positions = [0.1 * i for i in range(30)]
    close = []
    if mode == "raw":
        raw_pub = session.declare_publisher(TOPIC)
        close.append(raw_pub.undeclare)

        def send(seq: int, sec: int, ns: int) -> None:
            raw_pub.put(msgpack.packb({
                "header": {"stamp": {"sec": sec, "nanosec": ns}, "frame_id": str(seq)},
                "name": JOINTS, "position": positions, "velocity": positions, "effort": positions}))
    elif mode == "core":
        node = Node("bench_pub", session=session, log_level="warn")
        pub = node.create_publisher(JointState, "/" + TOPIC)
        close.append(node.destroy)

        def send(seq: int, sec: int, ns: int) -> None:
            msg = JointState(name=JOINTS, position=positions, velocity=positions, effort=positions)
            msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = sec, ns, str(seq)
            pub.publish(msg)
    else:
        import rclpy
        from rclpy.context import Context

        context = Context()
        os.environ["ZENOH_CONNECT"] = endpoint
        rclpy.init(args=["bench", "--ros-args", "--log-level", "warn"], context=context)
        rnode = rclpy.create_node("bench_pub", context=context)
        rpub = rnode.create_publisher(JointState, "/" + TOPIC, 10)
        close.append(lambda: (rnode.destroy_node(), context.try_shutdown()))

        def send(seq: int, sec: int, ns: int) -> None:
            msg = JointState(name=JOINTS, position=positions, velocity=positions, effort=positions)
            msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = sec, ns, str(seq)
            rpub.publish(msg)
    deadline = time.monotonic() + 120   # a loaded machine starts a Python process slowly
    while not ready and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.3)  # routes settle
    for seq, sec, ns in paced(count, rate):
        send(seq, sec, ns)
    try:
        out, _ = child.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        child.kill()
        out, _ = child.communicate()
    for fn in close:
        fn()
    ready_sub.undeclare()
    session.close()
    data = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"latencies_ns": [], "received": 0,
                                                                          "cpu": None}
    lat = sorted(x / 1000 for x in data["latencies_ns"])

    def pct(p: float) -> float:
        return lat[min(len(lat) - 1, int(p * len(lat)))] if lat else float("nan")

    return {"p50": pct(0.5), "p99": pct(0.99), "lost": count - data["received"],
            "cpu": 100.0 * data["cpu"] if data["cpu"] is not None else float("nan"),
            "sys": 100.0 * data["sys"] if "sys" in data else float("nan"),
            "switches": data.get("switches", float("nan"))}


def main() -> None:
    args = pacing_arguments(__doc__.splitlines()[0], MODES)
    modes = [m for m in MODES if m in args.modes]
    load_before = os.getloadavg()[0]
    results = interleaved_runs(modes, args.runs, lambda mode, endpoint: run_once(mode, endpoint, args.rate,
                                                                                 args.seconds))
    def median(values: list[float]) -> float:
        finite = [v for v in values if v == v]   # a run that received nothing has no figures
        return statistics.median(finite) if finite else float("nan")

    figures = ("p50", "p99", "cpu", "sys", "switches")
    med = {m: {k: median([r[k] for r in runs]) for k in figures} for m, runs in results.items()}
    lost = {m: sum(r["lost"] for r in runs) for m, runs in results.items()}
    print(f"30-joint JointState at {args.rate:g} Hz, {args.seconds:g} s x {args.runs} runs (medians)")
    print(f"{'path':<34}{'p50 µs':>10}{'p99 µs':>10}{'CPU %':>8}{'sys %':>8}{'cs/msg':>8}{'lost':>8}")
    labels = {"raw": "raw zenoh + msgpack", "core": "nodes.core pair (spin)", "rclpy": "rclpy pair (rclpy.spin)"}
    for mode in modes:
        print(f"{labels[mode]:<34}{med[mode]['p50']:>10.1f}{med[mode]['p99']:>10.1f}{med[mode]['cpu']:>8.1f}"
              f"{med[mode]['sys']:>8.1f}{med[mode]['switches']:>8.2f}{lost[mode]:>8}")
    print(f"load average (1 min) before / after: {load_before:.1f} / {os.getloadavg()[0]:.1f} "
          f"({os.cpu_count()} cores shared with other jobs)")
    summary = {f"{m}_{k}": round(med[m][k], 2 if k == "switches" else 1) for m in modes for k in figures}
    summary.update({f"{m}_lost": lost[m] for m in modes})
    if "rclpy" in med and "core" in med:
        summary["rclpy_to_core_p50"] = round(med["rclpy"]["p50"] / med["core"]["p50"], 3)
        summary["rclpy_to_core_cpu"] = round(med["rclpy"]["cpu"] / med["core"]["cpu"], 3)
    summary.update({"messages_per_run": int(args.rate * args.seconds), "runs": args.runs})
    print(json.dumps(summary))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        subscriber(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
    else:
        main()
