"""Collision shapes of a mesh-heavy robot: building them cold against loading them from the mesh cache.

Each run is a fresh Python process that builds the robot as the simulator does on a spawn (``Entity``: the
URDF checked, frame links merged, every mesh read through ``nodes.meshes`` and converted, DART's skeleton
built), with ``ZENROID_MESH_CACHE`` empty (cold) or filled by an earlier run (cached). The robot is
example-robot-data's Unitree G1 (51 binary STL meshes, 499,375 triangles) when it is installed
(``pip install example-robot-data``), else a generated robot of 30 icosphere meshes.

    python bench/meshes.py [--runs 3] [--modes hull,decompose]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import child_env  # noqa: E402 - after the path is set

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from pathlib import Path
from nodes.meshes.convert import set_collision_policy
from nodes.sim.entity import Entity, EntitySpec
robot = Path(sys.argv[2])
set_collision_policy(sys.argv[3])
started = time.perf_counter()
entity = Entity(EntitySpec(name="robot", xml=robot.read_text(), base_uri=robot.as_uri()))
seconds = time.perf_counter() - started
skeleton = entity.skeleton
shapes = sum(skeleton.getBodyNode(i).getNumShapeNodes() for i in range(skeleton.getNumBodyNodes()))
print(json.dumps({"seconds": seconds, "bodies": skeleton.getNumBodyNodes(), "shape_nodes": shapes}))
"""


def g1() -> Path | None:
    try:
        from nodes.urdf.paths import package_root

        root, _ = package_root("example-robot-data")
    except Exception:   # not installed
        return None
    path = root / "robots" / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf"
    return path if path.is_file() else None


def generated(folder: Path) -> Path:
    """30 links in a chain, each with an icosphere mesh (1,280 triangles) as visual and collision."""
    import trimesh

    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    links, joints = [], []
    for i in range(30):
        trimesh.creation.icosphere(subdivisions=3, radius=0.05 + 0.001 * i).export(folder / "meshes" / f"l{i}.stl")
        geometry = f"<geometry><mesh filename='meshes/l{i}.stl'/></geometry>"
        links.append(f"<link name='l{i}'><inertial><mass value='1'/><inertia ixx='0.01' iyy='0.01' izz='0.01' "
                     f"ixy='0' ixz='0' iyz='0'/></inertial><visual>{geometry}</visual>"
                     f"<collision>{geometry}</collision></link>")
        if i:
            joints.append(f"<joint name='j{i}' type='revolute'><parent link='l{i - 1}'/><child link='l{i}'/>"
                          "<origin xyz='0 0 0.1'/><axis xyz='0 1 0'/><limit lower='-1' upper='1' effort='10' "
                          "velocity='1'/></joint>")
    path = folder / "robot.urdf"
    path.write_text(f"<robot name='generated'>{''.join(links)}{''.join(joints)}</robot>")
    return path


def run_once(robot: Path, mode: str, cache: Path) -> dict:
    env = child_env({"ZENROID_MESH_CACHE": str(cache)})
    out = subprocess.run([sys.executable, "-c", CHILD, str(ROOT), str(robot), mode], capture_output=True,
                         text=True, env=env, timeout=1800, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--modes", default="hull,decompose")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-meshes-") as tmp:
        robot = g1() or generated(Path(tmp) / "robot")
        name = "g1" if "g1_description" in str(robot) else "generated"
        result = {"bench": "meshes", "robot": name, "runs": args.runs, "load": os.getloadavg()[0]}
        rows = []
        for mode in args.modes.split(","):
            cold, cached = [], []
            for run in range(args.runs):
                cache = Path(tmp) / f"cache-{mode}-{run}"
                first = run_once(robot, mode, cache)
                cold.append(first["seconds"])
                cached.append(run_once(robot, mode, cache)["seconds"])
            result[mode] = {"cold_s": statistics.median(cold), "cached_s": statistics.median(cached),
                            "shape_nodes": first["shape_nodes"], "bodies": first["bodies"]}
            rows.append((mode, f"{statistics.median(cold):.2f}", f"{statistics.median(cached):.2f}",
                         str(first["shape_nodes"])))
    print(json.dumps(result))
    print(f"\n{name}: spawn (Entity) time, median of {args.runs} fresh processes")
    print(f"{'collision_mesh':<16}{'cold s':>10}{'cached s':>10}{'shapes':>8}")
    for mode, cold_s, cached_s, shapes in rows:
        print(f"{mode:<16}{cold_s:>10}{cached_s:>10}{shapes:>8}")


if __name__ == "__main__":
    main()
