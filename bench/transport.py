"""One-way latency and loss of a 30-joint JointState between two processes:
our runtime (Node publisher → Node subscription, executor and inline callbacks) vs raw zenoh-python + msgpack,
measured in the same run, interleaved. Prints a table, then one JSON line.

    python bench/transport.py [--rate 1000] [--seconds 3] [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import interleaved_runs  # noqa: E402 - after the path is set (bench scripts run from anywhere)

JOINTS = [f"joint_{i}" for i in range(30)]


# ------------------------------------------------------------------ subscriber side (child process)

def subscriber(mode: str, endpoint: str, count: int, ready_key: str) -> None:
    import threading

    import msgpack
    import zenoh

    from nodes.core.session import open_peer

    latencies: list[int] = []
    seqs: set[int] = set()
    done = threading.Event()

    def record(stamp_sec: int, stamp_ns: int, seq: int) -> None:
        latencies.append(time.perf_counter_ns() - (stamp_sec * 1_000_000_000 + stamp_ns))
        seqs.add(seq)
        if len(seqs) >= count:
            done.set()

    if mode == "raw":
        session = open_peer([endpoint])

        def on_raw(sample: zenoh.Sample) -> None:
            m = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
            st = m["header"]["stamp"]
            record(st["sec"], st["nanosec"], int(m["header"]["frame_id"]))

        sub = session.declare_subscriber("bench/joint_states", on_raw)
        session.put(ready_key, b"1")
        done.wait(60)
        sub.undeclare()
        session.close()
    else:
        import msgs
        from nodes.core import Inline, Node

        JointState = msgs.get_type("sensor_msgs/msg/JointState")
        node = Node("bench_sub", connect=[endpoint], log_level="warn")

        def on_msg(msg) -> None:
            record(msg.header.stamp.sec, msg.header.stamp.nanosec, int(msg.header.frame_id))
            if done.is_set():
                node.request_shutdown()

        node.create_subscription(JointState, "/bench/joint_states", on_msg,
                                 delivery=Inline() if mode == "inline" else None)
        node.session.put(ready_key, b"1")
        if mode == "inline":
            done.wait(60)
        else:
            while not done.is_set() and node.ok:
                node.spin_once(0.05)
        node.destroy()
    print(json.dumps({"latencies_ns": latencies, "received": len(seqs)}), flush=True)


# ------------------------------------------------------------------ publisher side (this process)

def paced(count: int, rate: float) -> Iterator[tuple[int, int, int]]:
    """``(seq, sec, nanosec)`` ``count`` times at ``rate`` Hz, each stamped (perf_counter) as it is due."""
    period = 1.0 / rate
    next_t = time.perf_counter()
    for seq in range(count):
        sec, ns = divmod(time.perf_counter_ns(), 1_000_000_000)
        yield seq, sec, ns
        next_t += period
        delay = next_t - time.perf_counter()
        if delay > 0:
            time.sleep(delay)


def received_by(child: subprocess.Popen, timeout: float) -> tuple[list[float], int]:
    """What the subscriber process reported: its one-way latencies (µs, sorted) and how many it received."""
    try:
        out, _ = child.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        child.kill()
        out, _ = child.communicate()
    data = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"latencies_ns": [], "received": 0}
    return sorted(x / 1000 for x in data["latencies_ns"]), data["received"]


def run_once(mode: str, endpoint: str, rate: float, seconds: float) -> dict:
    import msgpack

    import msgs
    from nodes.core import Node

    count = int(rate * seconds)
    ready_key = f"bench/ready/{mode}/{os.getpid()}/{time.monotonic_ns()}"
    node = Node("bench_pub", connect=[endpoint], log_level="warn")
    ready = []
    node.session.declare_subscriber(ready_key, lambda s: ready.append(1))
    child = subprocess.Popen([sys.executable, __file__, "--child", mode, endpoint, str(count), ready_key],
                             stdout=subprocess.PIPE, text=True, cwd=ROOT)
    deadline = time.monotonic() + 30
    while not ready and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.3)  # routes settle
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    pub = node.create_publisher(JointState, "/bench/joint_states")
    raw_pub = node.session.declare_publisher("bench/joint_states")
    positions = [0.1 * i for i in range(30)]
    for seq, sec, ns in paced(count, rate):
        if mode == "raw":
            raw_pub.put(msgpack.packb({
                "header": {"stamp": {"sec": sec, "nanosec": ns}, "frame_id": str(seq)},
                "name": JOINTS, "position": positions, "velocity": positions, "effort": positions,
            }))
        else:
            msg = JointState(name=JOINTS, position=positions, velocity=positions, effort=positions)
            msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = sec, ns, str(seq)
            pub.publish(msg)
    lat, received = received_by(child, 10)
    raw_pub.undeclare()
    node.destroy()

    def pct(p: float) -> float:
        return lat[min(len(lat) - 1, int(p * len(lat)))] if lat else float("nan")

    return {"p50": pct(0.5), "p99": pct(0.99), "lost": count - received, "sent": count}


def pacing_arguments(description: str, modes: Sequence[str] = ()) -> argparse.Namespace:
    """``--rate`` (Hz), ``--seconds`` per run, ``--runs``: the options of the paced-publisher benches; with
    ``modes``, ``--modes`` picks some of them (comma-separated)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--runs", type=int, default=3)
    if modes:
        parser.add_argument("--modes", type=lambda text: [m for m in text.split(",") if m],
                            default=list(modes), help=f"comma-separated, of {','.join(modes)}")
    args = parser.parse_args()
    if modes and (unknown := [m for m in args.modes if m not in modes]):
        parser.error(f"--modes: unknown {','.join(unknown)} (known: {','.join(modes)})")
    return args


def main() -> None:
    args = pacing_arguments(__doc__.splitlines()[0])

    results = interleaved_runs(("raw", "runtime", "inline"), args.runs,
                               lambda mode, endpoint: run_once(mode, endpoint, args.rate, args.seconds))

    med = {m: {k: statistics.median(r[k] for r in runs) for k in ("p50", "p99")} for m, runs in results.items()}
    lost = {m: sum(r["lost"] for r in runs) for m, runs in results.items()}
    print(f"30-joint JointState at {args.rate:g} Hz, {args.seconds:g} s x {args.runs} runs (medians)")
    print(f"{'path':<28}{'p50 µs':>10}{'p99 µs':>10}{'lost':>8}")
    labels = {"raw": "raw zenoh + msgpack", "runtime": "runtime (executor callback)", "inline": "runtime (inline callback)"}
    for mode in ("raw", "runtime", "inline"):
        print(f"{labels[mode]:<28}{med[mode]['p50']:>10.1f}{med[mode]['p99']:>10.1f}{lost[mode]:>8}")
    summary = {
        "runtime_p50_us": round(med["runtime"]["p50"], 1), "runtime_p99_us": round(med["runtime"]["p99"], 1),
        "inline_p50_us": round(med["inline"]["p50"], 1), "inline_p99_us": round(med["inline"]["p99"], 1),
        "raw_p50_us": round(med["raw"]["p50"], 1), "raw_p99_us": round(med["raw"]["p99"], 1),
        "ratio_p50": round(med["runtime"]["p50"] / med["raw"]["p50"], 3),
        "inline_ratio_p50": round(med["inline"]["p50"] / med["raw"]["p50"], 3),
        "runtime_lost": lost["runtime"], "inline_lost": lost["inline"], "raw_lost": lost["raw"],
        "messages_per_run": int(args.rate * args.seconds), "runs": args.runs,
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        subscriber(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
    else:
        main()
