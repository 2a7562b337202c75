"""What a bag costs: writing (what ``zenroid bag record`` does per message), reading and decoding every
message (what ``zenroid bag play`` does before publishing), and ``bag info`` (in process and as the CLI).

A typical recording: 22-joint JointStates, TF frames (20 transforms) at a tenth of that and our own
HumanoidState (humanoid_msgs, not a standard type) at a tenth. Prints a table, then one JSON line.

    python bench/bag.py [--messages 20000] [--storage mcap|sqlite3] [--repeats 3]
"""

from __future__ import annotations

import argparse
import inspect
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import msgs  # noqa: E402
from nodes.bag.reader import open_bag  # noqa: E402
from nodes.bag.writer import BagWriter  # noqa: E402

JOINTS = [f"joint_{i}" for i in range(22)]


def typical_messages(n: int) -> list[tuple[str, Any]]:
    js_type = msgs.get_type("sensor_msgs/msg/JointState")
    tf_type = msgs.get_type("tf2_msgs/msg/TFMessage")
    state_type = msgs.get_type("humanoid_msgs/msg/HumanoidState")
    stamped = msgs.get_type("geometry_msgs/msg/TransformStamped")
    items: list[tuple[str, Any]] = []
    for i in range(n):
        p = [0.001 * i + 0.1 * j for j in range(len(JOINTS))]
        js = js_type(name=JOINTS, position=p, velocity=p, effort=p)
        js.header.stamp = msgs.time_from_sec(i * 0.001)
        items.append(("humanoid/joint_states", js))
        if i % 10 == 0:
            tf = tf_type(transforms=[stamped(child_frame_id=f"link_{k}") for k in range(20)])
            items.append(("tf", tf))
            items.append(("humanoid/state", state_type(joint_names=JOINTS, joint_positions=p, zmp_x=0.01 * i)))
    return items


def _writer(path: Path, storage: str) -> Any:
    if "storage" in inspect.signature(BagWriter).parameters:
        return BagWriter(path, storage=storage)
    if storage != "mcap":
        raise SystemExit(f"this tree's BagWriter writes mcap only, not {storage}")
    return BagWriter(path)


def write(path: Path, items: list[tuple[str, Any]], storage: str) -> float:
    t0 = time.perf_counter()
    writer = _writer(path, storage)
    for i, (key, msg) in enumerate(items):
        writer.write(key, msg, 1_700_000_000_000_000_000 + i * 100_000)
    writer.close()
    return time.perf_counter() - t0


def read(path: Path, n: int) -> float:
    t0 = time.perf_counter()
    count = sum(1 for _ in open_bag(path).messages())
    assert count == n, (count, n)
    return time.perf_counter() - t0


def info(path: Path) -> float:
    t0 = time.perf_counter()
    open_bag(path).info()
    return time.perf_counter() - t0


def cli_info(path: Path) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "nodes.tools", "bag", "info", str(path)], check=True, cwd=ROOT,
                   capture_output=True)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=20000, help="JointStates (TF, state: a tenth each)")
    parser.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    items = typical_messages(args.messages)
    n = len(items)
    runs: dict[str, list[float]] = {"write": [], "read": [], "info": [], "cli_info": []}
    size = 0
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            path = Path(tmp) / f"bag{r}"
            runs["write"].append(write(path, items, args.storage))
            runs["read"].append(read(path, n))
            runs["info"].append(info(path))
            runs["cli_info"].append(cli_info(path))
            size = sum(f.stat().st_size for f in path.iterdir())
    best = {k: min(v) for k, v in runs.items()}
    result = {
        "bench": "bag", "storage": args.storage, "messages": n, "size_bytes": size,
        "write_msgs_per_s": round(n / best["write"]), "read_msgs_per_s": round(n / best["read"]),
        "write_us_per_msg": round(best["write"] / n * 1e6, 2), "read_us_per_msg": round(best["read"] / n * 1e6, 2),
        "info_ms": round(best["info"] * 1e3, 2), "cli_info_ms": round(best["cli_info"] * 1e3, 1),
        "median_write_s": round(statistics.median(runs["write"]), 3),
    }
    print(f"{'step':<10}{'best':>12}  per message")
    print(f"{'write':<10}{best['write']:>11.3f}s  {result['write_us_per_msg']} µs")
    print(f"{'read':<10}{best['read']:>11.3f}s  {result['read_us_per_msg']} µs")
    print(f"{'info':<10}{best['info'] * 1e3:>10.2f}ms")
    print(f"{'cli info':<10}{best['cli_info'] * 1e3:>10.1f}ms")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
