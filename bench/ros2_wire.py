"""What the ROS 2 wire (rmw_zenoh mirror) costs: CDR codec speed, publish cost and one-way latency of a
22-joint JointState (the humanoid's joint_states) with the wire off, on without a ROS 2 subscriber (idle,
the lazy case) and on with one (CDR encoded and sent), and what a node costs to create with the wire off and
on (its graph tokens, its /parameter_events publisher and, on the wire, rcl_interfaces' six parameter
services; wall and process CPU time). Prints a table, then one JSON line.

    python bench/ros2_wire.py [--rate 1000] [--seconds 3] [--runs 3]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import interleaved_runs  # noqa: E402 - after the path is set (bench scripts run from anywhere)
from bench.transport import paced, pacing_arguments, received_by  # noqa: E402

JOINTS = [f"joint_{i}" for i in range(22)]
JS = "sensor_msgs/msg/JointState"
MODES = ("off", "idle", "ros2")


def _sample() -> dict:
    p = [0.1 * i for i in range(len(JOINTS))]
    return {"header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": ""}, "name": JOINTS, "position": p,
            "velocity": p, "effort": p}


def codec(n: int = 20000) -> dict[str, float]:
    """µs per 22-joint JointState: ours (generated), mcap-ros2-support's dynamic codec, rosbags."""
    import msgpack
    import numpy as np
    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic
    from rosbags.typesys import Stores, get_typestore

    from msgs import cdr
    from msgs.schema_text import full_definition

    data = _sample()
    packed = msgpack.packb(data)
    raw = cdr.encode(JS, data)
    mcap_enc = serialize_dynamic(JS, full_definition(JS))[JS]
    mcap_dec = generate_dynamic(JS, full_definition(JS))[JS]
    store = get_typestore(Stores.ROS2_JAZZY)
    msg = store.deserialize_cdr(raw, JS)
    msg.position = np.array(data["position"])

    def per(fn) -> float:
        best = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            for _ in range(n // 3):
                fn()
            best = min(best, (time.perf_counter() - t0) / (n // 3) * 1e6)
        return best

    return {
        "ours_encode_from_msgpack_us": per(lambda: cdr.encode(JS, msgpack.unpackb(packed, raw=False))),
        "ours_decode_us": per(lambda: cdr.decode(JS, raw)),
        "mcap_encode_from_msgpack_us": per(lambda: mcap_enc(msgpack.unpackb(packed, raw=False))),
        "mcap_decode_us": per(lambda: mcap_dec(raw)),
        "rosbags_encode_us": per(lambda: store.serialize_cdr(msg, JS)),
        "rosbags_decode_us": per(lambda: store.deserialize_cdr(raw, JS)),
    }


def run_once(mode: str, endpoint: str, rate: float, seconds: float) -> dict:
    """One run: a node publishing joint_states (publish_raw, as the broadcaster does) to a zenroid
    subscriber in a child process (bench/transport.py's), with the ROS 2 wire in ``mode``."""
    import msgpack

    import msgs
    from nodes.core import Node
    from nodes.core.ros2 import names
    from nodes.core.session import open_peer

    os.environ["ZENROID_ROS2"] = "0" if mode == "off" else "1"
    count = int(rate * seconds)
    ready_key = f"bench/ready/{mode}/{os.getpid()}/{time.monotonic_ns()}"
    node = Node("bench_pub", connect=[endpoint], log_level="warn")
    ready = []
    node.session.declare_subscriber(ready_key, lambda s: ready.append(1))
    child = subprocess.Popen([sys.executable, str(ROOT / "bench" / "transport.py"), "--child", "inline", endpoint,
                              str(count), ready_key], stdout=subprocess.PIPE, text=True, cwd=ROOT,
                             env={**os.environ, "ZENROID_ROS2": "0"})
    pub = node.create_publisher(msgs.get_type(JS), "/bench/joint_states")
    ros_side = None
    cdr_received = [0]
    if mode == "ros2":  # a ROS 2 subscription: its token (as rmw_zenoh declares it) and its Zenoh subscriber
        ros_side = open_peer([endpoint])
        key = names.data_key(0, "/bench/joint_states", JS)
        keep = [ros_side.declare_subscriber(key, lambda s: cdr_received.__setitem__(0, cdr_received[0] + 1))]
        keep.append(ros_side.liveliness().declare_token(names.endpoint_token(
            0, str(ros_side.info.zid()), 0, 1, names.SUBSCRIPTION, "/", "ros_listener", "/bench/joint_states", JS,
            names.DEFAULT_QOS)))
    deadline = time.monotonic() + 30
    while (not ready or (mode == "ros2" and not pub._mirror.active)) and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.3)  # routes settle
    positions = [0.1 * i for i in range(len(JOINTS))]
    cost_ns = 0
    for seq, sec, ns in paced(count, rate):
        payload = msgpack.packb({"header": {"stamp": {"sec": sec, "nanosec": ns}, "frame_id": str(seq)},
                                 "name": JOINTS, "position": positions, "velocity": positions, "effort": positions})
        t0 = time.perf_counter_ns()
        pub.publish_raw(payload)
        cost_ns += time.perf_counter_ns() - t0
    lat, received = received_by(child, 20)
    time.sleep(0.2)
    node.destroy()
    if ros_side is not None:
        ros_side.close()
    return {"p50": lat[len(lat) // 2] if lat else float("nan"),
            "p99": lat[min(len(lat) - 1, int(0.99 * len(lat)))] if lat else float("nan"),
            "publish_us": cost_ns / count / 1000, "lost": count - received, "cdr": cdr_received[0]}


def node_cost(nodes: int = 40, rounds: int = 7) -> dict[str, float]:
    """Median ms to create one node (``nodes`` sharing a session, then destroyed), wire off and on in turn."""
    from nodes.core import Node
    from nodes.core.session import open_peer

    def once(mode: str, endpoint: str) -> dict:
        os.environ["ZENROID_ROS2"] = "0" if mode == "off" else "1"
        session = open_peer([endpoint])
        try:
            start, cpu = time.perf_counter(), time.process_time()
            made = [Node(f"n{i}", namespace="cost", session=session, log_level="warn") for i in range(nodes)]
            took, cpu = time.perf_counter() - start, time.process_time() - cpu
            for node in made:
                node.destroy()
        finally:
            session.close()
        return {"ms": took / nodes * 1000, "cpu_ms": cpu / nodes * 1000}

    runs = interleaved_runs(("off", "on"), rounds, once)
    return {f"node_{k}_{mode}": statistics.median(r[k] for r in results) for mode, results in runs.items()
            for k in ("ms", "cpu_ms")}


def main() -> None:
    args = pacing_arguments(__doc__.splitlines()[0])

    node_ms = node_cost()
    codec_us = codec()
    results = interleaved_runs(MODES, args.runs, lambda mode, endpoint: run_once(mode, endpoint, args.rate,
                                                                                  args.seconds))
    med = {m: {k: statistics.median(r[k] for r in runs) for k in ("p50", "p99", "publish_us")}
           for m, runs in results.items()}
    lost = {m: sum(r["lost"] for r in runs) for m, runs in results.items()}
    cdr_sent = sum(r["cdr"] for r in results["ros2"])
    print("CDR codec, 22-joint JointState (µs per message, best of 3)")
    for k, v in codec_us.items():
        print(f"  {k:<32}{v:>8.1f}")
    print(f"\njoint_states (22 joints) at {args.rate:g} Hz, {args.seconds:g} s x {args.runs} runs (medians), "
          "zenroid subscriber in another process")
    print(f"{'ROS 2 wire':<34}{'publish µs':>11}{'p50 µs':>9}{'p99 µs':>9}{'lost':>6}")
    labels = {"off": "off (ros2:=false)", "idle": "on, no ROS 2 subscriber (lazy)", "ros2": "on, ROS 2 subscriber"}
    for m in MODES:
        print(f"{labels[m]:<34}{med[m]['publish_us']:>11.1f}{med[m]['p50']:>9.1f}{med[m]['p99']:>9.1f}{lost[m]:>6}")
    print(f"CDR messages received by the ROS 2 side: {cdr_sent} of {int(args.rate * args.seconds) * args.runs}")
    print(f"creating a node (40 on one session, median of 7): {node_ms['node_ms_off']:.2f} ms with the wire off, "
          f"{node_ms['node_ms_on']:.2f} ms on; process CPU {node_ms['node_cpu_ms_off']:.2f} / "
          f"{node_ms['node_cpu_ms_on']:.2f} ms")
    summary = {f"{m}_{k}": round(med[m][k], 1) for m in MODES for k in ("publish_us", "p50", "p99")}
    summary.update({f"{m}_lost": lost[m] for m in MODES})
    summary.update({k: round(v, 1) for k, v in codec_us.items()})
    summary.update({k: round(v, 2) for k, v in node_ms.items()})
    summary.update({"cdr_received": cdr_sent, "messages_per_run": int(args.rate * args.seconds), "runs": args.runs})
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
