"""Full-tree forward kinematics of the humanoid: ours (nodes.kinematics) vs yourdfpy, same run.

Prints a small table, then one JSON line: {"ours_us", "yourdfpy_us", "speedup", ...} (medians).
Usage: python bench/fk.py [--robot robots/humanoid.urdf] [--iterations 2000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import msgpack
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nodes.kinematics import KinematicTree  # noqa: E402
from nodes.state_publisher import TransformTree  # noqa: E402
from nodes.urdf import load_robot_description, parse_urdf  # noqa: E402


def per_call_us(fn, configs: np.ndarray, repeats: int) -> float:
    """Median over repeats of the mean time per call, in microseconds."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for q in configs:
            fn(q)
        samples.append((time.perf_counter() - start) / len(configs) * 1e6)
    return statistics.median(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default=str(ROOT / "robots" / "humanoid.urdf"))
    parser.add_argument("--iterations", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    import yourdfpy

    xml = load_robot_description(args.robot)
    tree = KinematicTree(parse_urdf(xml))
    urdf = yourdfpy.URDF.load(args.robot, build_scene_graph=True, load_meshes=False)
    rng = np.random.default_rng(0)
    configs = rng.uniform(-1.0, 1.0, size=(args.iterations, tree.num_dofs))
    yourdfpy_order = [tree.dof_index[n] for n in urdf.actuated_joint_names]
    links = tree.link_names

    def ours(q: np.ndarray) -> np.ndarray:
        return tree.link_transforms(q)

    tf_tree = TransformTree(xml)
    stamp = {"sec": 0, "nanosec": 0}

    def ours_tf(q: np.ndarray) -> bytes:
        # What the state publisher does per tf message: joint poses -> TransformStamped maps -> msgpack.
        tf_tree.positions[:] = q
        return msgpack.packb({"transforms": tf_tree.movable_transforms(stamp)})

    def theirs(q: np.ndarray) -> list[np.ndarray]:
        urdf.update_cfg(q[yourdfpy_order])
        return [urdf.get_transform(link, tree.root) for link in links]

    # Same answer before timing anything.
    q = configs[0]
    assert np.allclose(np.array(theirs(q)), ours(q), atol=1e-9), "ours and yourdfpy disagree"

    ours_us = per_call_us(ours, configs, args.repeats)
    tf_us = per_call_us(ours_tf, configs, args.repeats)
    theirs_us = per_call_us(theirs, configs[: max(200, args.iterations // 5)], args.repeats)
    batch = rng.uniform(-1.0, 1.0, size=(1000, tree.num_dofs))
    start = time.perf_counter()
    tree.link_transforms(batch)
    batch_us = (time.perf_counter() - start) / len(batch) * 1e6

    rows = [
        ("ours: all link transforms", ours_us),
        ("ours: one encoded tf message (state publisher)", tf_us),
        ("ours: batched, per configuration (1000)", batch_us),
        ("yourdfpy: update_cfg + get_transform x links", theirs_us),
    ]
    print(f"FK of '{tree.model.name}': {tree.num_dofs} joints, {len(links)} links")
    print(f"{'method':<48}{'us / update':>12}")
    for label, value in rows:
        print(f"{label:<48}{value:>12.1f}")
    print(json.dumps({
        "robot": tree.model.name, "dofs": tree.num_dofs, "links": len(links),
        "ours_us": round(ours_us, 1), "ours_tf_us": round(tf_us, 1), "ours_batched_us": round(batch_us, 2),
        "yourdfpy_us": round(theirs_us, 1), "speedup": round(theirs_us / ours_us, 1),
    }))


if __name__ == "__main__":
    main()
